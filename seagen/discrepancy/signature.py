"""The residual's signature: what it depends on, in words, and the catalogue effects ranked by likeness."""

from __future__ import annotations

import numpy as np

from seagen import fmath
from seagen.discrepancy.replay import Runs, simulate
from seagen.discrepancy.residuals import FAST_MM_S, SCORE_CHANNELS, STILL_MM_S, nut_speed
from seagen.plant import PlantConfig
from seagen.plant.config import CATALOGUE, Motor

FORCE_ON_SHARE = 0.025  # 'under load' above this share of control.force_max_n (the paper's 0.5 N of 20 N)
REVERSAL_S = 0.15  # 'at a reversal': within this time after the command changes sign
WORDS = {
    "direction": "the direction of motion (push vs retract)",
    "speed": "the speed (near zero vs at speed)",
    "reversal": "motion reversals",
    "force": "the force level",
    "angle": "the contact angle",
    "current": "the motor current (and its recent history)",
    "since_motion": "the time since the actuator last moved",
    "drift": "drift over the session",
    "offset": "a constant part (an offset)",
}
MIN_R2 = 0.15  # a dependence is named when it alone explains this share of a channel's residual
DEPENDS = 2.0  # a channel's residual is described when its RMS exceeds this many noise sigmas


def _since(event: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Seconds since `event` was last true along each row (large before the first event)."""
    idx = np.arange(event.shape[1])[None, :]
    last = np.maximum.accumulate(np.where(event, idx, -1), axis=1)
    then = np.take_along_axis(t, np.maximum(last, 0), axis=1)
    return np.where(last >= 0, t - then, 1e4)


def features(runs: Runs, motor: Motor, force_max_n: float) -> dict[str, np.ndarray]:
    """Per sample basis columns of each dependence group, shape (n, T, k); padding masked by runs.mask.
    Speed classes scale with `motor`'s no-load nut speed (residuals.nut_speed), the force band with
    `force_max_n`."""
    v = runs.speed("enc") * motor.mm_per_count
    still, fast = nut_speed(motor, STILL_MM_S), nut_speed(motor, FAST_MM_S)
    moving = np.abs(v) > still
    cmd = np.sign(runs.applied)
    flip = np.zeros_like(moving)
    flip[:, 1:] = (cmd[:, 1:] != cmd[:, :-1]) & (cmd[:, 1:] != 0)
    cur = np.abs(motor.current(runs.applied, v))  # the plant's own estimate, from the base config
    lag = np.zeros_like(cur)
    step = np.clip(np.diff(runs.t, axis=1) / 0.1, 0.0, 1.0)
    for j in range(1, cur.shape[1]):  # 0.1 s first-order lag of |i|
        lag[:, j] = lag[:, j - 1] + (cur[:, j] - lag[:, j - 1]) * step[:, j - 1]
    force = np.nan_to_num(runs.meas["force_n"])
    t = np.where(runs.mask, runs.t, np.nan)
    t = np.fmax.accumulate(np.nan_to_num(t, nan=-1.0), axis=1)
    session = t + np.r_[0.0, np.cumsum(t[:, -1])[:-1]][:, None]  # trials in recorded order, back to back
    angles = np.unique(runs.angle)
    return {
        "direction": np.stack([v > still, v < -still], -1).astype(float),
        "speed": np.stack([~moving, moving & (np.abs(v) < fast), np.abs(v) >= fast], -1).astype(float),
        "reversal": (_since(flip, t) < REVERSAL_S)[..., None].astype(float),
        "force": np.stack([force, force**2, force > FORCE_ON_SHARE * force_max_n], -1).astype(float),
        "angle": np.stack([runs.angle[:, None] == a for a in angles], -1).astype(float)
        * np.ones_like(t)[..., None],
        "current": np.stack([cur, lag], -1),
        "since_motion": fmath.exp(-_since(moving, t) / 0.3)[..., None],
        "drift": session[..., None],
    }


def _r2(y: np.ndarray, x: np.ndarray) -> float:
    """Share of y's variance a least-squares fit on x (with intercept) explains."""
    a = np.column_stack([np.ones(len(y)), x])
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    var = float(np.var(y))
    return 0.0 if var <= 0 else float(max(0.0, 1 - np.var(y - a @ coef) / var))


def profile(
    z: dict[str, np.ndarray], runs: Runs, feats: dict[str, np.ndarray]
) -> dict[str, dict[str, float]]:
    """R^2 of each dependence group alone, per scored channel, plus the channel's RMS ('rms')."""
    m = runs.mask
    out = {}
    for c in SCORE_CHANNELS:
        y = np.nan_to_num(z[c][m])
        row = {k: _r2(y, f[m]) for k, f in feats.items()}
        row["rms"] = float(np.sqrt(np.mean(y**2)))
        row["offset"] = float(np.mean(y) ** 2 / max(np.mean(y**2), 1e-12))
        out[c] = row
    return out


def vector(prof: dict[str, dict[str, float]]) -> np.ndarray:
    """A profile as one vector: each channel's R^2 per group, weighted by the channel's share of the RMS."""
    total = sum(p["rms"] ** 2 for p in prof.values()) or 1.0
    return np.array([p["rms"] ** 2 / total * p[k] for p in prof.values() for k in WORDS])


def describe(prof: dict[str, dict[str, float]]) -> list[str]:
    """The profile in words: per channel with a clear residual, what it depends on."""
    lines = []
    for c, p in prof.items():
        if p["rms"] < DEPENDS:
            continue
        deps = sorted(((p[k], k) for k in WORDS if p[k] >= MIN_R2), reverse=True)
        what = ", ".join(f"{WORDS[k]} (R² {r:.2f})" for r, k in deps) or "none of the named signals"
        lines.append(f"the {c} residual ({p['rms']:.1f} noise sigmas RMS) depends on {what}")
    return lines


def probe_sets(base: PlantConfig) -> dict[str, dict[str, dict[str, float]]]:
    """Each catalogue effect at its catalogue values (added), or its parameters 30 % higher (recalibrated)."""
    from dataclasses import fields

    out = {}
    for e in CATALOGUE:
        eff = base.effect(e) if base.on(e) else type(base.effect(e))()
        vals = {f.name: float(getattr(eff, f.name)) for f in fields(eff) if f.name != "enabled"}
        out[e] = {e: {k: v * 1.3 if base.on(e) else v for k, v in vals.items()}}
    return out


def rank(
    base: PlantConfig, runs: Runs, sigma: dict, z: dict[str, np.ndarray], feats: dict[str, np.ndarray]
) -> list[tuple[str, float]]:
    """Catalogue effects ranked by how alike their own signature and the residual's are (cosine)."""
    target = vector(profile(z, runs, feats))
    probes = probe_sets(base)
    sim = simulate(base, [{}] + list(probes.values()), runs)
    scores = []
    for i, e in enumerate(probes, start=1):
        dz = {c: (sim[c][i] - sim[c][0]) / sigma[c][:, None] for c in SCORE_CHANNELS}
        v = vector(profile(dz, runs, feats))
        cos = float(v @ target / (np.linalg.norm(v) * np.linalg.norm(target) + 1e-12))
        scores.append((e, cos))
    return sorted(scores, key=lambda s: -s[1])
