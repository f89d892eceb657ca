"""Replay measured trials through a plant: batched, noise-free, with per-element effect parameters."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from seagen import geometry as g
from seagen.data.protocol import SAMPLE_EVERY
from seagen.plant import Plant, PlantConfig
from seagen.plant.config import CATALOGUE, LEARNED_INPUTS
from seagen.plant.sim import learned_correction

CHANNELS = ("enc", "pot", "load_cell_n", "force_n")
# Sensor-side effects: they do not change the motion, so the replay loop applies them per element.
POST_HOC = ("pot_voltage_drop", "transport_delay", "load_cell_offset")
# Parameter values that make an enabled effect do nothing (exactly: same numbers as the effect off).
NEUTRAL: dict[str, dict[str, float]] = {
    "actuator_friction": {"force_n": 0.0, "reverse_ratio": 1.0},
    "linkage_friction": {"c0_n": 0.0, "c1_n": 0.0, "c2_n": 0.0},
    "viscous_friction": {"b_n_s_per_mm": 0.0},
    "stribeck_friction": {"extra_static_n": 0.0, "v_s_mm_s": 1.0},
    "series_compliance": {"k_n_per_mm": 5000.0, "beta_mm_per_n2": 0.0},
    "backlash": {"half_width_mm": 0.0},
    "spring_preload": {"force_n": 0.0},
    "spring_nonlinearity": {"k3_n_per_mm3": 0.0},
    "pot_voltage_drop": {"counts_per_unit_current": 0.0, "time_constant_s": 0.1},
    "load_cell_offset": {"offset_n": 0.0},
    "transport_delay": {"delay_s": 0.0},
}
ParamSet = dict[str, dict[str, float]]


@dataclass
class Runs:
    """Measured trials padded to one length: per-trial angle, applied command and signals (n, T)."""

    angle: np.ndarray
    volts: np.ndarray  # command applied during the interval after each sample
    meas: dict[str, np.ndarray]
    mask: np.ndarray
    names: list[str]

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
        )


def runs_from_frames(frames: list[tuple[str, pd.DataFrame]]) -> Runs:
    """Split each (source name, DataFrame) by its `trial` column and pad the trials into arrays."""
    trials = []
    for src, df in frames:
        for key, part in df.groupby("trial", sort=False):
            trials.append((f"{src}#{key}", part.sort_values("t_s", kind="stable")))
    n, t = len(trials), max(len(p) for _, p in trials)
    volts = np.zeros((n, t))
    meas = {c: np.full((n, t), np.nan) for c in CHANNELS}
    mask = np.zeros((n, t), dtype=bool)
    angle = np.zeros(n)
    for i, (_, p) in enumerate(trials):
        m = len(p)
        angle[i] = float(p["angle_set_deg"].iloc[0])
        v = p["motor_v"].to_numpy(dtype=float)
        # the command recorded with sample j+1 is the one applied between samples j and j+1
        volts[i, : m - 1], volts[i, m - 1 :] = v[1:], v[-1]
        for c in CHANNELS:
            meas[c][i, :m] = p[c].to_numpy(dtype=float)
        mask[i, :m] = True
    return Runs(angle, volts, meas, mask, [name for name, _ in trials])


def _value(base: PlantConfig, s: ParamSet, effect: str, param: str) -> float:
    """A parameter for one set: the set's own, else the base's (if on), else neutral."""
    if param in s.get(effect, {}):
        return float(s[effect][param])
    return float(getattr(base.effect(effect), param)) if base.on(effect) else NEUTRAL[effect][param]


def _per_element(values: list[float], n: int) -> np.ndarray | float:
    """Values per set repeated over the n trials; a plain float when all sets agree (faster stepping)."""
    return float(values[0]) if len(set(values)) == 1 else np.repeat(values, n)


def union_config(base: PlantConfig, sets: list[ParamSet], n: int) -> tuple[PlantConfig, dict]:
    """A config whose effect parameters are arrays over sets x trials, and the sensor-side arrays."""
    used = {e for s in sets for e in s}
    cfg = base.with_effect("pot_noise", False).with_effect("learned_residual", False)
    post: dict[str, dict[str, Any]] = {}
    for e in CATALOGUE:
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


def simulate(
    base: PlantConfig, sets: list[ParamSet], runs: Runs, inputs: dict[str, np.ndarray] | None = None
) -> dict[str, np.ndarray]:
    """Noise-free twins of every channel, shape (len(sets), n_trials, T), driven by the measured command.

    The base's learned residual (if on) is added to its channel; `inputs`, if given, is filled with the
    plant signals a learned residual reads (LEARNED_INPUTS), same shape."""
    n, t = runs.volts.shape
    e_n = n * len(sets)
    cfg, post = union_config(base, sets, n)
    plant = Plant(cfg, np.tile(runs.angle, len(sets)))
    volts = np.tile(runs.volts, (len(sets), 1))
    zero = np.zeros(e_n)
    pvd = post.get("pot_voltage_drop")
    kappa = pvd["counts_per_unit_current"] if pvd else zero
    alpha = np.minimum(cfg.dt_s / np.asarray(pvd["time_constant_s"]), 1.0) if pvd else zero
    delay = zero + (post["transport_delay"]["delay_s"] / cfg.dt_s if "transport_delay" in post else 0.0)
    offset = post["load_cell_offset"]["offset_n"] if "load_cell_offset" in post else zero
    size = int(np.ceil(delay.max())) + 2
    ring, ptr, drop, rows = np.zeros((size, e_n)), 0, np.zeros(e_n), np.arange(e_n)
    i0 = np.floor(delay).astype(int)
    frac = delay - i0
    out = {c: np.empty((e_n, t)) for c in CHANNELS}
    lr = base.effects.learned_residual
    rec = {k: np.empty((e_n, t)) for k in LEARNED_INPUTS} if inputs is not None or lr.enabled else {}
    for j in range(t):
        f = (1 - frac) * ring[(ptr - i0) % size, rows] + frac * ring[(ptr - i0 - 1) % size, rows]
        angle = g.angle_from_shaft(np.minimum(plant.shaft_mm, plant.y_contact))
        out["enc"][:, j] = plant.motor_mm / g.MM_PER_COUNT - 0.5  # expected value of the floored count
        out["pot"][:, j] = np.clip(g.pot_from_angle(angle) + drop, 0, g.ADC_MAX)
        out["load_cell_n"][:, j] = f * plant.ratio + offset
        for k, v in plant.learned_inputs().items() if rec else ():
            rec[k][:, j] = v
        out["force_n"][:, j] = out["load_cell_n"][:, j] / plant.ratio
        if j == t - 1:
            break
        for _ in range(SAMPLE_EVERY):
            plant.step(volts[:, j])
            if pvd:
                drop += (kappa * np.abs(plant.current) - drop) * alpha
            ptr = (ptr + 1) % size
            ring[ptr] = plant.shaft_force
    if lr.enabled:
        out[lr.channel] += learned_correction(lr, rec)
        out["force_n"] = out["load_cell_n"] / plant.ratio[:, None]
    if inputs is not None:
        inputs.update({k: v.reshape(len(sets), n, t) for k, v in rec.items()})
    return {c: v.reshape(len(sets), n, t) for c, v in out.items()}


def load_measured(path: str) -> list:
    """(name, DataFrame) for a CSV or every CSV in a directory, validated by the data schema."""
    from seagen.data.schema import DataError, load_csv

    p = Path(path)
    if p.is_dir():
        files = sorted(p.glob("*.csv"))
        if not files:
            raise DataError(f"{p}: no CSV files in this directory")
    elif p.exists():
        files = [p]
    else:
        raise DataError(f"{p}: no such file or directory")
    return [(f.name, load_csv(f)) for f in files]
