"""Bench experiments on the plant the paper ran on the real SEA (friction the paper's way)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seagen import geometry as g
from seagen.plant.config import PlantConfig

FRICTION_ANGLES_DEG = (8.0, 16.0, 26.0)  # where the paper's Fig. 8 values are reproduced
ONSET_BAND_N = (0.5, 3.0)  # reference-force band used to extrapolate the onset compression


def friction_from_trial(df: pd.DataFrame) -> float:
    """Friction (N) the paper's way: k_s x the compression at which the load cell leaves zero.

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
    return float(a * g.SPRING_N_PER_MM)


def measure_friction(
    cfg: PlantConfig, angles_deg: tuple[float, ...] = FRICTION_ANGLES_DEG, seed: int = 0, push_v: float = 1.5
) -> dict[float, float]:
    """Push slowly into the load cell at each angle and report the friction measured the paper's way."""
    from seagen.data.features import derive
    from seagen.data.protocol import Move, run_trials

    moves = [Move(a, push_v, 6.0, -4.0) for a in angles_deg]
    out = {}
    for a, df in zip(angles_deg, run_trials(cfg, moves, seed=seed), strict=True):
        df = df.assign(trial=0)
        out[a] = friction_from_trial(derive(df))
    return out
