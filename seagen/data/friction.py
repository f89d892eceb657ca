"""Bench experiments on the plant the paper ran on the real SEA (friction the paper's way)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seagen.geometry import Geometry, geometry
from seagen.plant.config import PlantConfig

ONSET_BAND_N = (0.5, 3.0)  # reference-force band used to extrapolate the onset compression


def friction_from_trial(df: pd.DataFrame, spring_n_per_mm: float) -> float:
    """Friction (N) the paper's way: k_s (the description's spring) x the compression at which the load
    cell leaves zero.

    The onset compression is found robustly: a line compression = a + b F fitted to the loading rows with
    reference force inside ONSET_BAND_N, evaluated at F = 0. `df` holds derived columns of one trial.
    """
    f = df["force_n"].to_numpy()
    comp = df["compression_mm"].to_numpy()
    peak = int(np.argmax(f))
    lo, hi = ONSET_BAND_N
    sel = np.zeros(len(f), dtype=bool)
    sel[: peak + 1] = (f[: peak + 1] > lo) & (f[: peak + 1] < hi)
    if sel.sum() < 3:
        return float("nan")
    b, a = np.polyfit(f[sel], comp[sel], 1)
    return float(a * spring_n_per_mm)


def friction_angles(geo: Geometry) -> tuple[float, float, float]:
    """Low, split and high contact angles (the paper's Fig. 8: 8, 16 and 26 deg on its 5 to 28 deg range)."""
    return (geo.angle_min_deg + 3.0, geo.split_deg, geo.angle_max_deg - 2.0)


def measure_friction(
    cfg: PlantConfig, angles_deg: tuple[float, ...] | None = None, seed: int = 0, push_v: float = 1.5
) -> dict[float, float]:
    """Push slowly into the load cell at each angle (friction_angles by default; `push_v` on the paper's
    motor, scaled to the actuator's) and report the friction measured the paper's way."""
    from seagen.data.features import derive
    from seagen.data.protocol import run_trials, scaled_move

    geo = geometry(cfg.actuator)
    angles_deg = friction_angles(geo) if angles_deg is None else angles_deg
    moves = [scaled_move(a, (push_v, 6.0, -4.0), cfg.actuator) for a in angles_deg]
    out = {}
    for a, df in zip(angles_deg, run_trials(cfg, moves, seed=seed), strict=True):
        df = df.assign(trial=0)
        out[a] = friction_from_trial(derive(df, geo), geo.spring_n_per_mm)
    return out
