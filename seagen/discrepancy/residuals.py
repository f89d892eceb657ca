"""Residuals in units of the noise, the noise floor, and where they are significant (t-test, Holm)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from seagen.actuator import default_actuator
from seagen.discrepancy.replay import CHANNELS, Runs
from seagen.plant.config import Motor

# force_n is load_cell_n / R_l(angle): in noise units the two residuals are identical, so the combined
# metric counts the load cell once.
SCORE_CHANNELS = ("enc", "pot", "load_cell_n")
QUANT_SIGMA = 1.0 / np.sqrt(12.0)  # rounding noise of an integer reading (enc has no other noise)
ALPHA = 0.01  # family-wise error rate of the region tests (Holm)
MIN_EFFECT = 0.25  # a region counts only if its mean residual is at least this many noise sigmas
FORCE_SHARES = (0.05, 0.25, 0.5)  # force-region edges, shares of control.force_max_n (1, 5, 10 N: paper)
# Nut-speed classes: still below the paper's 0.2 mm/s, fast above its 2 mm/s, as the same shares of another
# design's no-load nut speed (Motor.v_max_mm_s: 0.71 % and 7.1 % of the paper's 28.3 mm/s)
STILL_MM_S, FAST_MM_S = 0.2, 2.0
PAPER_V_MAX_MM_S = Motor.of(default_actuator()).v_max_mm_s


def nut_speed(motor: Motor, paper_mm_s: float) -> float:
    """The nut speed that is to `motor`'s no-load speed what `paper_mm_s` is to the paper's (exactly
    `paper_mm_s` on the paper's motor)."""
    return paper_mm_s * (motor.v_max_mm_s / PAPER_V_MAX_MM_S)


def noise_sigma(runs: Runs) -> dict[str, np.ndarray]:
    """Per-trial noise sigma of each channel: robust (MAD) spread of second differences / sqrt(6)."""
    out = {}
    for c in CHANNELS:
        x = runs.meas[c]
        d2 = x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2]
        if c in ("load_cell_n", "force_n"):  # a stretch held flat (a saturated or idle cell) has no noise
            d2 = np.where(d2 == 0, np.nan, d2)  # to show: a float reading with noise never repeats exactly
        mad = np.nanmedian(np.abs(d2 - np.nanmedian(d2, axis=1, keepdims=True)), axis=1)
        sig = 1.4826 * mad / np.sqrt(6.0)
        floor = QUANT_SIGMA if c in ("enc", "pot") else np.maximum(1e-3, resolution(x) * QUANT_SIGMA)
        out[c] = np.full(len(sig), QUANT_SIGMA) if c == "enc" else np.maximum(sig, floor)
    return out


def resolution(x: np.ndarray) -> np.ndarray:
    """Per trial, the smallest step between successive readings (0 when none): a channel read in steps
    of q (a quantised load cell) is uncertain by at least q / sqrt(12) even where its second differences
    vanish (for a float reading with noise the step is tiny and changes nothing)."""
    d = np.abs(np.diff(x, axis=1))
    tiny = 1e-9 * np.nanmax(np.abs(x), axis=1, initial=0.0)[:, None]  # float rounding, not a step
    d = np.where(np.isfinite(d) & (d > tiny), d, np.inf).min(axis=1)
    return np.where(np.isfinite(d), d, 0.0)


def zscores(runs: Runs, sim: dict[str, np.ndarray], sigma: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Measured minus simulated, in noise sigmas (the channel's noise and what the log clock's resolution
    does to it, Runs.timing_sigma); sim arrays may carry a leading set axis."""
    if not runs.res.any():
        return {c: (runs.meas[c] - sim[c]) / sigma[c][:, None] for c in CHANNELS}
    ts = runs.timing_sigma()
    return {c: (runs.meas[c] - sim[c]) / np.sqrt(sigma[c][:, None] ** 2 + ts[c] ** 2) for c in CHANNELS}


def chi2_per_trial(z: dict[str, np.ndarray]) -> np.ndarray:
    """Sum of squared residuals per trial over the scored channels (padding ignored)."""
    return sum(np.nansum(z[c] ** 2, axis=-1) for c in SCORE_CHANNELS)


def n_scored(runs: Runs) -> int:
    """Number of residual values the score sums over."""
    return int(runs.mask.sum()) * len(SCORE_CHANNELS)


def rms(z: dict[str, np.ndarray], where: np.ndarray | None = None) -> float:
    """Combined residual RMS (noise sigmas) over the scored channels, optionally in a region."""
    vals = [z[c][where] if where is not None else z[c] for c in SCORE_CHANNELS]
    return float(np.sqrt(np.nanmean(np.concatenate([v.ravel() for v in vals]) ** 2)))


def channel_rms(z: dict[str, np.ndarray], where: np.ndarray | None = None) -> dict[str, float]:
    """Residual RMS per scored channel (noise sigmas): over the non-NaN samples, or over the samples
    `where` is true (a NaN there counts as 0)."""
    if where is None:
        return {c: float(np.sqrt(np.nanmean(z[c] ** 2))) for c in SCORE_CHANNELS}
    return {c: float(np.sqrt(np.mean(np.nan_to_num(z[c][where]) ** 2))) for c in SCORE_CHANNELS}


def noise_floor(runs: Runs, sigma: dict[str, np.ndarray]) -> float:
    """Data-derived floor: RMS of the high-pass part (second differences / sqrt 6), in noise sigmas.

    The encoder has no analog noise: its floor is its rounding, exactly 1 sigma by definition.
    """
    parts = [np.ones(int(runs.mask.sum()))]
    for c in ("pot", "load_cell_n"):
        x = runs.meas[c]
        d2 = (x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2]) / np.sqrt(6.0) / sigma[c][:, None]
        lim = np.nanpercentile(np.abs(d2), 99)  # drop the kinks (contact, reversal), not the noise
        parts.append(d2[np.abs(d2) <= lim])
    return float(np.sqrt(np.mean(np.concatenate(parts) ** 2)))


def _bins(x: np.ndarray, edges: list[float], names: list[str]) -> np.ndarray:
    """Label each value by the bin it falls in."""
    return np.asarray(names, dtype=object)[np.digitize(x, edges)]


def region_labels(runs: Runs, motor: Motor, force_max_n: float) -> dict[str, np.ndarray]:
    """Region of every sample by contact angle, force level (FORCE_SHARES of the actuator's force range
    `force_max_n`), direction and speed (STILL_MM_S scaled to `motor`: nut_speed), estimated current."""
    enc = runs.meas["enc"]
    v = runs.speed("enc") * motor.mm_per_count  # nut speed, mm/s
    m = runs.mask
    cur = np.abs(motor.current(np.nan_to_num(runs.applied), v))  # the plant's own estimate (base config)
    speed = np.abs(v)
    still = nut_speed(motor, STILL_MM_S)
    moving = m & (speed > still)
    q = [float(np.percentile(speed[moving], 50)) if moving.any() else 1.0]
    cq = [float(np.nanpercentile(cur[m], p)) for p in (33, 67)]
    angle = np.broadcast_to(runs.angle[:, None], enc.shape)
    edges = [f * force_max_n for f in FORCE_SHARES]
    names = [
        f"<{edges[0]:g} N",
        *(f"{a:g}-{b:g} N" for a, b in zip(edges[:-1], edges[1:], strict=True)),
        f">{edges[-1]:g} N",
    ]
    return {
        "angle": np.vectorize(lambda a: f"{a:.1f} deg", otypes=[object])(angle),
        "force": _bins(runs.meas["force_n"], edges, names),
        "direction": _bins(v, [-still, still], ["retract", "still", "push"]),
        "speed": _bins(speed, [still, q[0]], ["still", "slow", "fast"]),
        "current": _bins(cur, cq, ["low |i|", "mid |i|", "high |i|"]),
    }


def holm(p: np.ndarray) -> np.ndarray:
    """Holm step-down adjusted p-values."""
    order = np.argsort(p)
    adj = np.minimum(1.0, np.maximum.accumulate((len(p) - np.arange(len(p))) * p[order]))
    out = np.empty_like(adj)
    out[order] = adj
    return out


def region_table(runs: Runs, z: dict[str, np.ndarray], labels: dict[str, np.ndarray]) -> pd.DataFrame:
    """One-sample t-test of the mean residual per region and channel, Holm-corrected, ranked."""
    rows = []
    for kind, lab in labels.items():
        for region in sorted(set(lab[runs.mask])):
            sel = runs.mask & (lab == region)
            for c in SCORE_CHANNELS:
                x = z[c][sel]
                t, p = stats.ttest_1samp(x, 0.0) if len(x) > 2 and np.std(x) > 0 else (0.0, 1.0)
                rows.append((kind, region, c, len(x), float(np.mean(x)), float(np.sqrt(np.mean(x**2))), t, p))
    df = pd.DataFrame(rows, columns=["by", "region", "channel", "n", "mean_z", "rms_z", "t", "p"])
    df["p_holm"] = holm(df["p"].fillna(1.0).to_numpy())
    df["significant"] = (df["p_holm"] < ALPHA) & (df["mean_z"].abs() >= MIN_EFFECT)
    df["size"] = df["mean_z"].abs()
    order = df.sort_values(["significant", "p_holm", "size"], ascending=[False, True, False])
    return order.drop(columns="size").reset_index(drop=True)
