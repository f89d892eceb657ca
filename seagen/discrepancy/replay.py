"""Replay measured trials through a plant: batched, noise-free, with per-element effect parameters."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from seagen.actuator import Actuator
from seagen.data.logimport import clock_resolution
from seagen.plant import Plant, PlantConfig, kernel
from seagen.plant.config import CATALOGUE, TERMS
from seagen.plant.sim import (
    RIGID_PER_SPRING,
    cell_distort,
    hysteresis_step,
    lag_step,
    learned_correction,
    pot_distort,
    pot_ripple,
    reading_alpha,
)

CHANNELS = ("enc", "pot", "load_cell_n", "force_n")
# Sensor-side effects: they do not change the motion, so the replay loop applies them per element (the
# kernel's list but the pot noise and the learned remainder, which the replay switches off: union_config).
POST_HOC = tuple(e for e in kernel.SENSOR_SIDE if e not in ("pot_noise", "learned_residual"))
# Parameter values that make an enabled effect do nothing (exactly: same numbers as the effect off); the
# series compliance's stiffness is the plant's rigid structure, relative to the actuator's spring (`neutral`).
NEUTRAL: dict[str, dict[str, float]] = {
    "actuator_friction": {"force_n": 0.0, "reverse_ratio": 1.0},
    "linkage_friction": {"c0_n": 0.0, "c1_n": 0.0, "c2_n": 0.0},
    "viscous_friction": {"b_n_s_per_mm": 0.0},
    "stribeck_friction": {"extra_static_n": 0.0, "v_s_mm_s": 1.0},
    "series_compliance": {"beta_mm_per_n2": 0.0},
    "backlash": {"half_width_mm": 0.0},
    "spring_preload": {"force_n": 0.0},
    "spring_nonlinearity": {"k3_n_per_mm3": 0.0},
    "pot_voltage_drop": {"counts_per_unit_current": 0.0, "time_constant_s": 0.1},
    "load_cell_offset": {"offset_n": 0.0},
    "transport_delay": {"delay_s": 0.0},
    # the term library (config.TERMS)
    "lead_error": {"amplitude_mm": 0.0, "period_mm": 1.0, "phase_rad": 0.0},
    "cogging": {"force_n": 0.0, "period_mm": 1.0, "phase_rad": 0.0},
    "spring_drift": {"share": 0.0, "time_constant_s": 1.0},
    "cell_drift": {"offset_n": 0.0, "time_constant_s": 1.0},
    "rate_friction": {"extra_n": 0.0, "v_c_mm_s": 1.0, "time_constant_s": 0.01},
    "bristle_friction": {"force_n": 0.0, "x0_mm": 1.0},
    "spring_hysteresis": {"k_n_per_mm": 0.0, "half_width_mm": 1.0},
    "spring_poly": {"k2_n_per_mm2": 0.0, "k3_n_per_mm3": 0.0},
    "cell_lag": {"time_constant_s": 0.0},
    "cell_quantisation": {"step_n": 0.0},
    "cell_saturation": {"limit_n": 1e12},
    "drive_saturation": {"limit_v": 1e12},
    "pot_lag": {"time_constant_s": 0.0},
    "pot_hysteresis": {"half_width_counts": 0.0},
    "pot_quantisation": {"step_counts": 0.0},
    "pot_drift": {"offset_counts": 0.0, "time_constant_s": 1.0},
    "pot_saturation": {"limit_counts": 1e12},
    "pot_reading_lag": {"time_constant_s": 0.0},
    "cell_soft_saturation": {"limit_n": 1e12, "sharpness": 2.0},
    "cell_hysteresis": {"force_n": 0.0, "width_n": 1.0, "shape": 1.0},
    "breakaway_friction": {"extra_n": 0.0, "v_s_mm_s": 1.0, "time_constant_s": 0.01, "shape": 2.0},
    "spring_bouc_wen": {"force_n": 0.0, "width_mm": 1.0, "shape": 1.0},
    "load_friction": {"mu": 0.0},
    "position_friction": {"extra_n": 0.0, "center_mm": 0.0, "width_mm": 1.0, "shape": 2.0},
    "spring_knee": {"dk_n_per_mm": 0.0, "onset_mm": 0.0},
    "drive_gain_drift": {"share": 0.0, "time_constant_s": 1.0},
    "current_limit": {"limit_share": 1e12},
    "cell_gain_drift": {"share": 0.0, "time_constant_s": 1.0},
    "pot_ripple": {"amplitude_counts": 0.0, "period_counts": 100.0, "phase_rad": 0.0},
}
ParamSet = dict[str, dict[str, float]]
SWITCH_V = 0.5  # a command change this large is a switch (its instant's uncertainty moves the encoder)
SETTLE_S = 0.03  # the speed after a switch is read this long after it (at least: 2 motor time constants)
# A command instant this close to a plant step's edge is on it: far below any log clock's resolution
# (1 us at the finest), far above the rounding of times summed in floating point (a simulator's t += dt).
SNAP_S = 1e-9


def settle_time(act: Actuator) -> float:
    """How long after a command switch the motor's speed is read as settled: SETTLE_S, or two of the
    motor's time constants when that is longer (the paper's 15 ms motor and the example's are within it)."""
    return max(SETTLE_S, 2.0 * act.motor.time_constant_s)


@dataclass
class Runs:
    """Measured trials padded to one length: per-trial angle, the logged command and signals (n, T) at
    their logged instants `t` (s from the trial's first row), and the command timing `lag` per trial.

    The command logged on row j takes effect at t_j - lag * (t_j - t_{j-1}): lag 0 = from its row on (a
    rig loop logs the command it computed and applies from that sample on), lag 1 = up to its row (seagen's
    schema: the command applied since the previous row). `res` is the log clock's resolution per trial (s;
    0 when the samples are the clock's own ticks). `declared` is the lag the log declares (a map's
    [log] command, or seagen's own logs), None when it is to be fitted."""

    angle: np.ndarray
    volts: np.ndarray  # the command as logged on each row
    meas: dict[str, np.ndarray]
    mask: np.ndarray
    names: list[str]
    t: np.ndarray
    lag: np.ndarray = field(default_factory=lambda: np.zeros(0))
    res: np.ndarray = field(default_factory=lambda: np.zeros(0))
    declared: float | None = None
    settle_s: float = SETTLE_S  # see timing_sigma; settle_time(actuator) for a motor slower than the paper's

    _tsig: dict[str, np.ndarray] | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        n, t = self.mask.shape
        if self.t.shape != (n, t):  # the logged instants, never a loop rate assumed
            raise ValueError(f"Runs.t has shape {self.t.shape}, the trials {(n, t)}")
        if self.lag.shape != (n,):
            self.lag = np.ones(n)
        if self.res.shape != (n,):
            self.res = np.zeros(n)

    def take(self, idx: np.ndarray | list[int]) -> Runs:
        """The subset of trials `idx`, trimmed to its longest trial."""
        idx = np.asarray(idx, dtype=int)
        t = int(self.mask[idx].sum(axis=1).max())
        return Runs(
            self.angle[idx],
            self.volts[idx, :t],
            {k: v[idx, :t] for k, v in self.meas.items()},
            self.mask[idx, :t],
            [self.names[i] for i in idx],
            self.t[idx, :t],
            self.lag[idx],
            self.res[idx],
            self.declared,
            self.settle_s,
        )

    def timing_sigma(self) -> dict[str, np.ndarray]:
        """Per sample and channel (n, T), what the log clock's resolution does to a comparison: the true
        instant of a row is uncertain by res/sqrt(12), so a channel is uncertain by |dx/dt| res/sqrt(12);
        the encoder also carries, from every command switch on, the speed change there times the
        uncertainty of the switch's instant (summed in quadrature). Zero for a log on its clock's ticks."""
        if self._tsig is None:
            u = (self.res / np.sqrt(12.0))[:, None]
            out = {c: np.abs(self.speed(c)) * u for c in CHANNELS}
            v = self.speed("enc")
            cmd = self.volts
            switch = np.zeros_like(self.mask)
            switch[:, 1:] = np.abs(np.diff(cmd, axis=1)) > SWITCH_V
            later = np.empty_like(v)
            for i in range(len(v)):  # the speed a settle time after each sample
                j = np.searchsorted(self.t[i], self.t[i] + self.settle_s)
                later[i] = v[i, np.minimum(j, v.shape[1] - 1)]
            before = np.concatenate([v[:, :1], v[:, :-1]], axis=1)
            jump = np.where(switch & self.mask, (later - before) ** 2, 0.0) * u**2
            out["enc"] = np.sqrt(out["enc"] ** 2 + np.cumsum(jump, axis=1))
            self._tsig = out
        return self._tsig

    @property
    def applied(self) -> np.ndarray:
        """The command in force during the interval after each sample (lag rounded to a convention)."""
        nxt = np.concatenate([self.volts[:, 1:], self.volts[:, -1:]], axis=1)
        return np.where(self.lag[:, None] >= 0.5, nxt, self.volts)

    def speed(self, channel: str = "enc") -> np.ndarray:
        """d(channel)/dt per sample (central differences on the logged instants; 0 at the padding)."""
        x, t = np.nan_to_num(self.meas[channel]), self.t
        out = np.zeros_like(x)
        if x.shape[1] < 2:
            return out
        xp = np.concatenate([x[:, :1], x, x[:, -1:]], axis=1)
        tp = np.concatenate([t[:, :1] - 1e-3, t, t[:, -1:] + 1e-3], axis=1)
        num = xp[:, 2:] - xp[:, :-2]
        den = tp[:, 2:] - tp[:, :-2]
        out = num / np.where(den > 0, den, 1.0)
        return np.where(self.mask, out, 0.0)


def runs_from_frames(frames: list[tuple[str, pd.DataFrame]], timing: dict | None = None) -> Runs:
    """Split each (source name, DataFrame) by its `trial` column and pad the trials into arrays.

    `timing` (what is known of the log: load_timing, or logimport.own_timing): "lag" pins the command
    timing (Runs.declared)."""
    trials = []
    for src, df in frames:
        for key, part in df.groupby("trial", sort=False):
            trials.append((f"{src}#{key}", part.sort_values("t_s", kind="stable")))
    n, t = len(trials), max(len(p) for _, p in trials)
    # the padding's period: a trial's own, or the session's median for a one-sample trial
    steps = [np.diff(p["t_s"].to_numpy(dtype=float)) for _, p in trials]
    pooled = np.concatenate(steps)
    session = float(np.median(pooled)) if pooled.size else 0.0  # every trial one sample: no padding
    volts = np.zeros((n, t))
    times = np.zeros((n, t))
    meas = {c: np.full((n, t), np.nan) for c in CHANNELS}
    mask = np.zeros((n, t), dtype=bool)
    angle = np.zeros(n)
    res = np.zeros(n)
    for i, (_, p) in enumerate(trials):
        m = len(p)
        angle[i] = float(p["angle_set_deg"].iloc[0])
        v = p["motor_v"].to_numpy(dtype=float)
        volts[i, :m], volts[i, m:] = v, v[-1]
        ts = p["t_s"].to_numpy(dtype=float)
        ts = ts - ts[0]
        step = float(np.median(np.diff(ts))) if m > 1 else session
        times[i, :m] = ts
        times[i, m:] = ts[-1] + step * np.arange(1, t - m + 1)
        res[i] = clock_resolution(ts)
        for c in CHANNELS:
            meas[c][i, :m] = p[c].to_numpy(dtype=float)
        mask[i, :m] = True
    pin = (timing or {}).get("lag")
    declared = None if pin is None else float(pin)
    lag = np.full(n, 1.0 if declared is None else declared)
    return Runs(angle, volts, meas, mask, [name for name, _ in trials], times, lag, res, declared)


def drive(runs: Runs, dt: float) -> np.ndarray:
    """The command each plant step of length dt sees, shape (n, K): the logged commands, each taking effect
    at its instant (t_j - lag * (t_j - t_{j-1})) and held until the next; a step a switch falls inside gets
    the time-weighted mean of the two (sub-step timing)."""
    n = len(runs.angle)
    m = runs.mask.sum(axis=1)
    k_max = int(np.ceil(float(max(runs.t[i, m[i] - 1] for i in range(n))) / dt - 1e-9)) + 1
    edges = np.arange(k_max + 1) * dt
    out = np.empty((n, k_max))
    for i in range(n):
        t, v = runs.t[i, : m[i]], runs.volts[i, : m[i]]
        s = np.empty(m[i])
        s[0] = -1.0
        s[1:] = t[1:] - runs.lag[i] * np.diff(t)
        s = np.maximum.accumulate(s)
        # an instant on a step edge up to the clock's float rounding takes effect from that edge: held
        # exactly, not a time-weighted mean across a 1e-18 s sliver (whose cancellation error, ~1e-9 V, a
        # stick-slip plant amplifies into encoder counts)
        k = np.rint(s / dt)
        s = np.where(np.abs(s - k * dt) < SNAP_S, k * dt, s)
        # integral of the piecewise-constant command at every step edge
        seg = np.diff(np.r_[s, np.inf])
        cum = np.r_[0.0, np.cumsum(v[:-1] * seg[:-1])]
        j = np.clip(np.searchsorted(s, edges, side="right") - 1, 0, m[i] - 1)
        u = cum[j] + v[j] * (edges - s[j])
        inside = np.clip(np.searchsorted(s, edges[1:], side="left") - 1, 0, m[i] - 1) == j[:-1]
        out[i] = np.where(inside, v[j[:-1]], np.diff(u) / dt)  # exact where no switch falls inside
    return out


def _sample_plan(runs: Runs, dt: float, k_max: int) -> tuple[np.ndarray, ...]:
    """Every read of a plant state by a logged instant, ordered by step: (bounds, trial, sample, weight,
    first). The reads of step k (state after k steps) are [bounds[k], bounds[k+1]); an instant between two
    steps is read linearly from both (`first`: the earlier of its reads, or its only one)."""
    tr, js = np.nonzero(runs.mask)
    pos = runs.t[tr, js] / dt
    a = np.floor(pos + 1e-9).astype(int)
    w = np.clip(pos - a, 0.0, 1.0)
    w[w < 1e-9] = 0.0
    k = np.r_[a, a[w > 0] + 1]
    rows = np.r_[tr, tr[w > 0]]
    cols = np.r_[js, js[w > 0]]
    wt = np.r_[1.0 - w, w[w > 0]]
    first = np.r_[np.ones(len(a), bool), np.zeros(int((w > 0).sum()), bool)]
    k = np.minimum(k, k_max)
    order = np.argsort(k, kind="stable")
    k, rows, cols, wt, first = k[order], rows[order], cols[order], wt[order], first[order]
    return np.searchsorted(k, np.arange(k_max + 2)), rows, cols, wt, first


def neutral(base: PlantConfig, effect: str, param: str) -> float:
    """The value of `param` that makes `effect`, enabled, do nothing on the plant of `base`."""
    if (effect, param) == ("series_compliance", "k_n_per_mm"):
        return base.actuator.stiffness_n_per_mm * RIGID_PER_SPRING  # the structure Plant has with it off
    return NEUTRAL[effect][param]


def _value(base: PlantConfig, s: ParamSet, effect: str, param: str) -> float:
    """A parameter for one set: the set's own, else the base's (if on), else neutral."""
    if param in s.get(effect, {}):
        return float(s[effect][param])
    return float(getattr(base.effect(effect), param)) if base.on(effect) else neutral(base, effect, param)


def _per_element(values: list[float], n: int) -> np.ndarray | float:
    """Values per set repeated over the n trials; a plain float when all sets agree (faster stepping)."""
    return float(values[0]) if len(set(values)) == 1 else np.repeat(values, n)


def union_config(base: PlantConfig, sets: list[ParamSet], n: int) -> tuple[PlantConfig, dict]:
    """A config whose effect parameters are arrays over sets x trials, and the sensor-side arrays."""
    used = {e for s in sets for e in s}
    cfg = base.with_effect("pot_noise", False).with_effect("learned_residual", False)
    post: dict[str, dict[str, Any]] = {}
    for e in CATALOGUE + TERMS:
        if e not in used and not base.on(e):
            continue
        params = [f.name for f in dataclasses.fields(base.effect(e)) if f.name != "enabled"]
        arrays = {p: _per_element([_value(base, s, e, p) for s in sets], n) for p in params}
        if e in POST_HOC:
            post[e] = arrays
            cfg = cfg.with_effect(e, False)
        else:
            cfg = cfg.with_effect(e, True, **arrays)  # type: ignore[arg-type]  # arrays broadcast like floats
    return cfg, post


def _motion_sets(base: PlantConfig, sets: list[ParamSet]) -> tuple[list[ParamSet], np.ndarray]:
    """The distinct motions of sets: sets that differ only in sensor-side effects (POST_HOC) or repeat
    another move the plant alike, so each motion is stepped once. (motion sets, motion index per set)."""
    phys = [{e: p for e, p in s.items() if e not in POST_HOC} for s in sets]
    keys: dict[tuple, int] = {}
    index = np.empty(len(sets), dtype=int)
    for i, s in enumerate(phys):
        key = tuple((e, tuple(sorted(s[e].items()))) for e in sorted(s))
        index[i] = keys.setdefault(key, len(keys))
    first = {j: i for i, j in reversed(list(enumerate(index)))}
    return [phys[first[j]] for j in range(len(keys))], index


def simulate(
    base: PlantConfig,
    sets: list[ParamSet],
    runs: Runs,
    inputs: dict[str, np.ndarray] | None = None,
    compiled: bool = True,
) -> dict[str, np.ndarray]:
    """Noise-free twins of every channel, shape (len(sets), n_trials, T), driven by the measured command.

    The plant steps at its own dt; each logged command takes effect at its own instant (see `drive`) and
    every channel is read at its row's logged instant. The base's learned residual (if on) is added to its
    channel; `inputs`, if given, is filled with the plant signals a learned residual reads (LEARNED_INPUTS),
    same shape. Sets that move the plant alike (they differ only in sensor-side effects) share one stepped
    motion; every batch element is independent of the others, so the numbers are those of one set alone.
    The motion is stepped by the compiled kernel (`plant/kernel.py`), or by `Plant` in Python when not
    `compiled` (the two agree to rounding)."""
    n, t = runs.volts.shape
    n_sets = len(sets)
    e_n = n * n_sets
    motions, which = _motion_sets(base, sets)
    cfg, _ = union_config(base, motions, n)
    _, post = union_config(base, sets, n)
    dt = cfg.dt_s
    plant = Plant(cfg, np.tile(runs.angle, len(motions)))
    u = np.tile(drive(runs, dt), (len(motions), 1))
    k_max = u.shape[1]
    bounds, tr, js, w, first = _sample_plan(runs, dt, k_max)
    # each read, per set: the set's element (row) and the element of its motion (mrow)
    rows = tr[:, None] + n * np.arange(n_sets)[None, :]
    mrows = tr[:, None] + n * which[None, :]
    zero = np.zeros(e_n)
    pvd = post.get("pot_voltage_drop")
    kappa = pvd["counts_per_unit_current"] if pvd else zero
    alpha = np.minimum(dt / np.asarray(pvd["time_constant_s"]), 1.0) if pvd else zero
    delay = zero + (post["transport_delay"]["delay_s"] / dt if "transport_delay" in post else 0.0)
    offset = zero + (post["load_cell_offset"]["offset_n"] if "load_cell_offset" in post else 0.0)
    of_set = np.repeat(which, n) * n + np.tile(np.arange(n), n_sets)  # each element's motion element
    lr = base.effects.learned_residual
    record = inputs is not None or lr.enabled
    n_sig = 5 if record else 4 if pvd else 3  # the states the reads below need
    traj = kernel.run(plant, u, n_sig) if compiled and kernel.available(plant) else _stepped(plant, u)
    # the plant states each read needs (the reads of step k see the states after k steps)
    ks = np.repeat(np.arange(k_max + 1), np.diff(bounds))[:, None]
    motor_mm, shaft_mm = traj.motor_mm[mrows, ks], traj.shaft_mm[mrows, ks]
    # the force the load cell sees: the motion's, or behind a set element's lag (cell_lag)
    fl = _Lagged(traj.force_n, post, "cell_lag", zero, of_set, dt, rows, mrows)
    if delay.any():  # the force i0 and i0 + 1 steps back (zero before the first step), weighted
        i0 = np.floor(delay).astype(int)
        frac = (delay - i0)[rows]
        back = ks - i0[rows]
        force = (1 - frac) * fl.read(np.maximum(back, 0)) + frac * fl.read(np.maximum(back - 1, 0))
    else:
        force = fl.read(ks)
    drops = None
    if pvd and traj.current is not None:  # filtered once per distinct (motion, gain, time constant)
        key = np.stack([of_set, zero + kappa, zero + alpha], axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        filt = kernel.pot_drop(traj.current, uniq[:, 0].astype(np.int64), uniq[:, 1], uniq[:, 2])
        drops = filt[inv.reshape(-1)[rows], ks]
    rec = {}
    if record:
        signals = {"force_n": traj.force_n, "speed_mm_s": traj.v_shaft, "current": traj.current}
        rec = {key: v[mrows, ks] for key, v in signals.items() if v is not None}
        rec["contact_deg"] = np.broadcast_to(plant.contact_deg[mrows], rows.shape).copy()
    r = rows
    pot0 = plant.geo.pot_from_angle(plant.geo.angle_from_shaft(np.minimum(shaft_mm, plant.y_contact[mrows])))
    if "pot_lag" in post:  # the pot's angle reading behind a set element's lag (pot_lag), after every step
        pl = _Lagged(None, post, "pot_lag", zero, of_set, dt, rows, mrows)
        if pl.slow.size:
            mel = of_set[pl.slow]  # only the motion elements a lag reads
            seen = np.minimum(traj.shaft_mm[mel], plant.y_contact[mel, None])
            pl.lag(plant.geo.pot_from_angle(plant.geo.angle_from_shaft(seen)), np.arange(mel.size))
            pot0 = pl.read(ks, pot0)
    if "pot_ripple" in post:  # periodic in the pot's angle reading, before its voltage drop
        pr = post["pot_ripple"]
        per = [(zero + pr[p])[r] for p in ("amplitude_counts", "period_counts", "phase_rad")]
        pot0 = pot0 + pot_ripple(pot0, *per)
    pot = pot0 + (drops if drops is not None else zero[r])
    readings = {
        "enc": motor_mm / plant.geo.mm_per_count - 0.5,  # E[floored count]
        "pot": np.clip(pot, 0, plant.geo.adc_max),
        "load_cell_n": _cell(force * plant.ratio[mrows] + offset[r], ks * dt, post, r, e_n),
    }
    shape = (n_sets, n, t)
    wr = w[:, None]
    once, twice = first, ~first
    at_once, at_twice = (tr[once], js[once]), (tr[twice], js[twice])  # (trial, sample) of each read

    def accumulate(x: np.ndarray) -> np.ndarray:
        """Weighted reads summed into (set, trial, sample), the earlier read first (as a running sum)."""
        out = np.zeros((x.shape[1], n, t))  # x's sets (all, or those a term is on in)
        y = wr * x
        out[:, at_once[0], at_once[1]] += y[once].T
        out[:, at_twice[0], at_twice[1]] += y[twice].T
        return out

    out = {c: accumulate(v) for c, v in readings.items()}
    hyst = _on(post, "cell_hysteresis", "force_n", n_sets, n)
    tip = accumulate((force * plant.ratio[mrows])[:, hyst]) if hyst.size else None
    rec = {k: accumulate(v) for k, v in rec.items()}
    ratio = plant.geo.linkage_ratio(runs.angle)[None, :, None]
    if lr.enabled:
        flat = {k: v.reshape(e_n, t) for k, v in rec.items()}
        out[lr.channel] += learned_correction(lr, flat).reshape(shape)
    out["pot"] = _pot(out["pot"], post, n_sets, n, runs.t)
    if tip is not None:
        par = {
            p: _per_set(post, "cell_hysteresis", p, n_sets, n)[hyst, :, 0] for p in NEUTRAL["cell_hysteresis"]
        }
        out["load_cell_n"][hyst] = _cell_hysteresis(out["load_cell_n"][hyst], tip, par)
    out["force_n"] = out["load_cell_n"] / ratio
    if inputs is not None:
        inputs.update(rec)
    return out


class _Lagged:
    """A trajectory x (motion elements, K + 1) read per set element, behind the first-order lag of `effect`
    (post-hoc) for the elements whose lag is not neutral (computed for those alone)."""

    def __init__(self, x, post: dict, effect: str, zero, of_set, dt: float, rows, mrows) -> None:
        tau = zero + (post[effect]["time_constant_s"] if effect in post else 0.0)
        alpha = np.minimum(dt / np.maximum(tau, 1e-300), 1.0)
        self.x, self.rows, self.mrows, self.alpha = x, rows, mrows, alpha
        self.slow = np.flatnonzero(alpha < 1.0)
        pos = np.zeros(len(alpha), dtype=np.int64)
        pos[self.slow] = np.arange(self.slow.size)
        self.pos, self.is_slow = pos[rows], (alpha < 1.0)[rows]
        self.lagged: np.ndarray | None = None
        if x is not None and self.slow.size:
            self.lag(x, of_set[self.slow])

    def lag(self, x: np.ndarray, which: np.ndarray) -> None:
        """The lagged rows `which` of x, one per slow element."""
        self.lagged = kernel.lagged(x, which, self.alpha[self.slow])

    def read(self, cols: np.ndarray, plain: np.ndarray | None = None) -> np.ndarray:
        """Every read at steps cols: the lagged value for a slow element, else `plain` (x's own)."""
        out = self.x[self.mrows, cols] if plain is None else plain
        if self.lagged is None:
            return out
        return np.where(self.is_slow, self.lagged[self.pos, cols], out)


def _cell(reading: np.ndarray, t: np.ndarray, post: dict, r: np.ndarray, n: int) -> np.ndarray:
    """The load-cell reads with the term library's sensor distortions of each read's set element (rows r,
    of n) at the reads' times t (sim.cell_distort); unchanged when none is in the replay."""
    cd, cs, cq = (post.get(e) for e in ("cell_drift", "cell_saturation", "cell_quantisation"))
    ss, cg = post.get("cell_soft_saturation"), post.get("cell_gain_drift")
    if not (cd or cs or cq or ss or cg):
        return reading

    def per(x):  # a parameter (scalar or per element) at every read
        return (np.zeros(n) + x)[r]

    return cell_distort(
        reading,
        t,
        (per(cd["offset_n"]), per(cd["time_constant_s"])) if cd else None,
        per(cs["limit_n"]) if cs else None,
        per(cq["step_n"]) if cq else None,
        (per(ss["limit_n"]), per(ss["sharpness"])) if ss else None,
        (per(cg["share"]), per(cg["time_constant_s"])) if cg else None,
    )


def _per_set(post: dict, effect: str, param: str, n_sets: int, n: int) -> np.ndarray:
    """A sensor-side parameter (scalar or per set element) as (sets, trials, 1)."""
    return (np.zeros(n_sets * n) + post[effect][param]).reshape(n_sets, n, 1)


def _on(post: dict, effect: str, param: str, n_sets: int, n: int) -> np.ndarray:
    """The sets in which a sensor-side term is on: its parameter `param` not at its neutral value (the
    others' reads are those without it, exactly, and are not computed again)."""
    if effect not in post:
        return np.zeros(0, dtype=np.int64)
    v = _per_set(post, effect, param, n_sets, n)[:, :, 0]
    return np.flatnonzero((v != NEUTRAL[effect][param]).any(axis=1))


def _pot(pot: np.ndarray, post: dict, n_sets: int, n: int, t: np.ndarray) -> np.ndarray:
    """The pot's reads (sets, trials, samples at the logged instants t) behind each set element's reading
    lag, with its drifting zero, through its play (from its first reading), in its steps and clamped above
    (sim.Plant.read); unchanged when none is in the replay. The term library's terms are computed for the
    sets they are on in (_on)."""
    ph, pq = post.get("pot_hysteresis"), post.get("pot_quantisation")
    lag = _on(post, "pot_reading_lag", "time_constant_s", n_sets, n)
    if lag.size:
        tau = _per_set(post, "pot_reading_lag", "time_constant_s", n_sets, n)[lag]
        a = reading_alpha(np.diff(t, axis=1)[None], tau)
        x = pot[lag]
        c = x[:, :, 0]
        for j in range(1, x.shape[2]):
            c = x[:, :, j] = lag_step(c, x[:, :, j], a[:, :, j - 1])
        pot[lag] = x
    drifting = _on(post, "pot_drift", "offset_counts", n_sets, n)
    if drifting.size:
        drift = (
            _per_set(post, "pot_drift", p, n_sets, n)[drifting] for p in ("offset_counts", "time_constant_s")
        )
        pot[drifting] = pot_distort(pot[drifting], t[None], tuple(drift))
    if ph:
        w = _per_set(post, "pot_hysteresis", "half_width_counts", n_sets, n)[:, :, 0]
        out = np.empty_like(pot)
        h = pot[:, :, 0]
        out[:, :, 0] = h
        for j in range(1, pot.shape[2]):
            h = np.minimum(np.maximum(h, pot[:, :, j] - w), pot[:, :, j] + w)
            out[:, :, j] = h
        pot = out
    if pq:
        q = _per_set(post, "pot_quantisation", "step_counts", n_sets, n)
        safe = np.where(q > 0, q, 1.0)
        pot = np.where(q > 0, safe * np.rint(pot / safe), pot)
    clamped = _on(post, "pot_saturation", "limit_counts", n_sets, n)
    if clamped.size:
        limit = _per_set(post, "pot_saturation", "limit_counts", n_sets, n)[clamped]
        pot[clamped] = pot_distort(pot[clamped], t[None], None, limit)
    return pot


def _cell_hysteresis(cell: np.ndarray, tip: np.ndarray, par: dict[str, np.ndarray]) -> np.ndarray:
    """The load cell's reads (sets, trials, samples) plus each set element's hysteresis h z (par: its
    parameters, (sets, trials)), z driven by the noise-free tip force's change per reading from the first
    (sim.hysteresis_step), after its other terms."""
    h, w, k = (par[p] for p in ("force_n", "width_n", "shape"))
    z = np.zeros(cell.shape[:2])
    out = cell.copy()
    for j in range(1, cell.shape[2]):
        z = hysteresis_step(z, tip[:, :, j] - tip[:, :, j - 1], w, k)
        out[:, :, j] += h * z
    return out


def _stepped(plant: Plant, u: np.ndarray) -> kernel.Trajectory:
    """Plant's states after every step of command u (n_elements, K), stepped in Python."""
    out = np.zeros((5, u.shape[0], u.shape[1] + 1))
    for k in range(u.shape[1]):
        plant.step(u[:, k])
        for i, x in enumerate(
            (plant.motor_mm, plant.shaft_mm, plant.shaft_force, plant.current, plant.v_shaft)
        ):
            out[i, :, k + 1] = x
    return kernel.Trajectory(*out)


def load_timing(path: str) -> dict:
    """What `data import` or `data generate` wrote about the log's timing (TIMING_FILE beside the CSVs the
    rows are read from, rows_place; import.json in folders imported before it), else {}."""
    import json

    from seagen.data.logimport import TIMING_FILE
    from seagen.data.schema import DataError

    p = rows_place(Path(path))
    folder = p if p.is_dir() else p.parent
    f = next((f for f in (folder / TIMING_FILE, folder / "import.json") if f.is_file()), None)
    if f is None:
        return {}
    try:
        out = json.loads(f.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise DataError(f"{f}: not valid JSON: {e}") from None
    if not isinstance(out, dict):
        raise DataError(f'{f}: must be a JSON object (keys such as "lag"), got {type(out).__name__}')
    lag = out.get("lag")
    if lag is not None and (isinstance(lag, bool) or not isinstance(lag, int | float) or not 0 <= lag <= 1):
        raise DataError(f"{f}: lag must be a number in [0, 1], got {lag!r}")
    return out


def rows_place(p: Path) -> Path:
    """Where the rows of `p` are read from: a folder `data import` wrote is read from its logged/ rows (each
    at its own instant), not its copy on the loop-rate grid; anything else as given."""
    from seagen.data.logimport import LOGGED

    return p / LOGGED if p.is_dir() and any((p / LOGGED).glob("*.csv")) else p


def load_measured(path: str) -> list:
    """(name, DataFrame) for a CSV or every CSV in a directory, validated by the data schema; a folder
    `data import` wrote is read from its logged/ rows (each at its own instant), not its loop-rate copy."""
    from seagen.data.schema import DataError, load_csv

    p = rows_place(Path(path))
    if p.is_dir():
        files = sorted(p.glob("*.csv"))
        if not files:
            raise DataError(f"{p}: no CSV files in this directory")
    elif p.exists():
        files = [p]
    else:
        raise DataError(f"{p}: no such file or directory")
    return [(f.name, load_csv(f)) for f in files]
