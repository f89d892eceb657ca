"""Float references of every model kind, and the paper-style errors of a task (the one place for both)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from seagen.errors import UserError
from seagen.fit import kinematics
from seagen.geometry import Geometry
from seagen.modelfile import FeatureSpec

TASKS = ("calibration", "control")
TARGET = {"calibration": "force_n", "control": "compression_mm"}
UNIT = {"calibration": "N", "control": "mm"}


def predict(model: dict[str, Any], df: pd.DataFrame) -> np.ndarray:
    """Float reference output of a model dict on a derived data frame (`seagen.data.features.derive`)."""
    kind = model.get("kind")
    if kind == "sf":
        from seagen.fit.sf import eval_sf

        a, b = model["sf"]["inputs"]
        return eval_sf(model["sf"], df[a].to_numpy(dtype=float), df[b].to_numpy(dtype=float))
    if kind == "mlp":
        from seagen.fit.mlp import predict_mlp

        spec = FeatureSpec.from_dict(model["features"], where="model features")
        return predict_mlp(model["module"], spec, df)
    raise UserError(f"model kind {kind!r} is not 'sf' or 'mlp'")


def kinematics_predict(task: str, df: pd.DataFrame, geo: Geometry | None = None) -> np.ndarray:
    """Naive kinematics (Eq. 1-2, constant friction) of the actuator `geo` (the paper's when None): force
    from compression, or its inverse for control."""
    if task == "calibration":
        return kinematics.shaft_force(df["compression_mm"].to_numpy(), geo=geo)
    return kinematics.compression_for(df["force_n"].to_numpy(dtype=float), geo)


def task_errors(task: str, pred: np.ndarray, df: pd.DataFrame, threshold_n: float) -> dict[str, float]:
    """Paper-style errors (rows with reference force > threshold_n: kinematics.error_threshold_n of the
    data's actuator); control errors are in mm, with _mm aliases."""
    angle = df["angle_set_deg"].to_numpy()
    force = df["force_n"].to_numpy(dtype=float)
    if task == "calibration":
        return kinematics.relative_errors(np.asarray(pred, dtype=float), force, angle, threshold_n)
    sel = force > threshold_n
    ref = df["compression_mm"].to_numpy(dtype=float)[sel]
    errs = kinematics.relative_errors(np.asarray(pred, dtype=float)[sel], ref, angle[sel], threshold_n=0.0)
    errs.update({k.replace("_n", "_mm"): v for k, v in errs.items() if k.endswith("_n")})
    return errs
