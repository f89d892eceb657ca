"""The float feature function: raw signals -> angle, compression and the pipeline's finite differences."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seagen.data.schema import DataError
from seagen.geometry import Geometry, geometry
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
PERIOD_TOL = 0.02  # a median row step within 2 % of the loop period is the loop's (a ms clock's 9/10/11 ms)


def sample_period(df: pd.DataFrame) -> float | None:
    """The median step between consecutive rows of a trial (s); None without a time column or with fewer
    than two rows per trial."""
    if "t_s" not in df.columns:  # rows built in memory (the cloud predictor's last samples)
        return None
    t = df["t_s"].to_numpy(dtype=float)
    same = df["trial"].to_numpy()[1:] == df["trial"].to_numpy()[:-1]
    d = np.diff(t)[same]
    d = d[d > 0]
    return float(np.median(d)) if d.size else None


def check_sample_period(df: pd.DataFrame, loop_hz: float) -> None:
    """Refuse rows not at the control loop's period (the actuator description's control.loop_hz): the
    d_/dd_ features are per-sample differences, so a model trained on them at another rate would be
    silently mis-scaled on the firmware (DataError, exit 2)."""
    step = sample_period(df)
    period = 1.0 / loop_hz
    if step is None or abs(step - period) <= PERIOD_TOL * period:
        return
    where = df.attrs.get("source", "the data")
    raise DataError(
        f"{where}: rows are {step * 1000:.4g} ms apart ({1 / step:.4g} Hz), but the feature pipeline's "
        f"differences are per sample at the control loop's {loop_hz:g} Hz; use the "
        f"{loop_hz:g} Hz copy `seagen data import` writes (its --out folder; the logged rows are "
        f"in logged/) or resample every trial to a {period * 1000:g} ms grid"
    )


def derive(df: pd.DataFrame, geo: Geometry | None = None) -> pd.DataFrame:
    """Add derived columns: angle_deg (Eq. 5), compression_mm (Eq. 2) and the d_/dd_ differences of the
    feature pipeline's base signals (its Python twin, seagen.runtime.features: same table, same warm-up),
    with the geometry of the actuator the rows came from (the paper's when None). Rows must be at that
    actuator's control-loop period (check_sample_period)."""
    geo = geo or geometry()
    check_sample_period(df, geo.actuator.loop_hz)
    out = df.copy()
    out["angle_deg"] = geo.angle_from_pot(df["pot"].to_numpy())
    out["compression_mm"] = geo.compression_mm(out["angle_deg"].to_numpy(), df["enc"].to_numpy())
    trial = df["trial"].to_numpy()
    for i in (F.ENC, F.POT, F.COMP):
        d, dd = F.over_trials(out[F.BASE_NAMES[i]].to_numpy(), trial)
        out[F.name_of(F.D, i)], out[F.name_of(F.DD, i)] = d, dd
    return out
