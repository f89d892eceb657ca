"""The textbook estimate (Eq. 1, 2, 6) with constant friction compensation: the baseline to beat."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seagen.actuator import Actuator
from seagen.geometry import Geometry, geometry

# Relative errors are taken over rows whose reference force exceeds this share of the actuator's force
# range (control.force_max_n): the paper's 5 N of its 20 N.
ERROR_SHARE = 0.25


def error_threshold_n(act: Actuator) -> float:
    """The reference force (N) above which rows count in the paper-style relative errors of `act`."""
    return ERROR_SHARE * act.control.force_max_n


def shaft_force(
    compression_mm: np.ndarray, compensation_n: float | None = None, geo: Geometry | None = None
) -> np.ndarray:
    """Eq. 1 at the SEA output shaft: k_s * compression - F_fa (tip force divided by R_l), with k_s and
    F_fa (unless given) from the actuator description (the paper's when `geo` is None)."""
    geo = geo or geometry()
    comp = geo.friction_n if compensation_n is None else compensation_n
    return geo.spring_n_per_mm * np.asarray(compression_mm, dtype=float) - comp


def compression_for(force_n: np.ndarray, geo: Geometry | None = None) -> np.ndarray:
    """The inverse of shaft_force: the compression that gives `force_n` at the shaft (control task)."""
    geo = geo or geometry()
    return (np.asarray(force_n, dtype=float) + geo.friction_n) / geo.spring_n_per_mm


def relative_errors(
    pred: np.ndarray, ref: np.ndarray, angle: np.ndarray, threshold_n: float
) -> dict[str, float]:
    """Paper-style errors: average over rows with ref > threshold; maximum = worst contact angle's mean.

    Absolute errors (N) use the same rows. Percentages are |pred - ref| / ref * 100.
    """
    sel = ref > threshold_n
    err = np.abs(pred[sel] - ref[sel])
    pct = err / ref[sel] * 100.0
    groups = pd.Series(err).groupby(angle[sel])
    groups_pct = pd.Series(pct).groupby(angle[sel])
    return {
        "error_avg_n": float(err.mean()),
        "error_max_n": float(groups.mean().max()),
        "error_avg_pct": float(pct.mean()),
        "error_max_pct": float(groups_pct.mean().max()),
        "rows": int(sel.sum()),
    }


def kinematics_errors(df: pd.DataFrame, geo: Geometry | None = None) -> dict[str, float]:
    """Errors of the naive kinematics estimate on a derived data frame (needs compression_mm) of the actuator
    `geo` (the paper's when None)."""
    geo = geo or geometry()
    pred = shaft_force(df["compression_mm"].to_numpy(), geo=geo)
    threshold = error_threshold_n(geo.actuator)
    return relative_errors(pred, df["force_n"].to_numpy(), df["angle_set_deg"].to_numpy(), threshold)
