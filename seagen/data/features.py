"""The float feature function: raw signals -> angle, compression and the pipeline's finite differences."""

from __future__ import annotations

import pandas as pd

from seagen import geometry as g
from seagen.runtime import features as F

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


def derive(df: pd.DataFrame) -> pd.DataFrame:
    """Add derived columns: angle_deg (Eq. 5), compression_mm (Eq. 2) and the d_/dd_ differences of the
    feature pipeline's base signals (its Python twin, seagen.runtime.features: same table, same warm-up)."""
    out = df.copy()
    out["angle_deg"] = g.angle_from_pot(df["pot"].to_numpy())
    out["compression_mm"] = g.compression_mm(out["angle_deg"].to_numpy(), df["enc"].to_numpy())
    trial = df["trial"].to_numpy()
    for i in (F.ENC, F.POT, F.COMP):
        d, dd = F.over_trials(out[F.BASE_NAMES[i]].to_numpy(), trial)
        out[F.name_of(F.D, i)], out[F.name_of(F.DD, i)] = d, dd
    return out
