"""The one feature function: raw signals -> angle, compression and finite differences (C mirrors it)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seagen import geometry as g

# Order of the calibration MLP's nine inputs (paper §V-A).
MLP_FEATURES = (
    "pot",
    "enc",
    "compression_mm",
    "d_pot",
    "d_enc",
    "d_compression_mm",
    "dd_pot",
    "dd_enc",
    "dd_compression_mm",
)
SAMPLE_RATE_HZ = 100.0


def differences(x: np.ndarray, trial: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Backward first and second differences per sample, restarting at every trial.

    Warm-up: at a trial's first sample both previous values are taken equal to the sample itself, so
    d = x[n] - x[n-1] and dd = x[n] - 2 x[n-1] + x[n-2] with x[-1] = x[-2] = x[0].
    """
    x = np.asarray(x)
    start = np.r_[True, trial[1:] != trial[:-1]]
    prev1 = np.r_[x[:1], x[:-1]]
    prev1 = np.where(start, x, prev1)
    start2 = start | np.r_[False, start[:-1]]
    prev2 = np.r_[x[:1], prev1[:-1]]
    prev2 = np.where(start2, prev1, prev2)
    return x - prev1, x - 2 * prev1 + prev2


def derive(df: pd.DataFrame) -> pd.DataFrame:
    """Add derived columns: angle_deg (Eq. 5), compression_mm (Eq. 2) and d_/dd_ of enc, pot, compression."""
    out = df.copy()
    trial = df["trial"].to_numpy()
    out["angle_deg"] = g.angle_from_pot(df["pot"].to_numpy())
    out["compression_mm"] = g.compression_mm(out["angle_deg"].to_numpy(), df["enc"].to_numpy())
    for col in ("enc", "pot", "compression_mm"):
        d, dd = differences(out[col].to_numpy(), trial)
        out[f"d_{col}"], out[f"dd_{col}"] = d, dd
    return out
