"""Predictors available to the closed loop: the kinematic inverse (the generated models: seagen.setups)."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import numpy as np
import pandas as pd

from seagen.control.loop import CloudPredictor, McuPredictor
from seagen.fit.predict import kinematics_predict
from seagen.geometry import Geometry
from seagen.runtime.control import KinParams, predict_kinematic

KIN = KinParams()


def _kin_ctx(k: KinParams) -> Callable[[ModuleType], object]:
    """The C context maker of the kinematic predictor with constants `k`."""

    def make(mod: ModuleType) -> object:
        from seagen.toolchain.controller import kin_ctx

        return kin_ctx(mod, k)

    return make


def kinematic_mcu(predict_every: int = 1, k: KinParams = KIN) -> McuPredictor:
    """The fixed-point kinematic inverse, sea_predict_kinematic, on the MCU (constants `k`: the paper's by
    default, KinParams.of(actuator) for another design)."""
    return McuPredictor("sea_predict_kinematic", _kin_ctx(k), lambda: predict_kinematic(k), predict_every)


def kinematic_float(
    geo: Geometry | None = None,
) -> Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """The kinematic inverse in float of the actuator `geo` (the paper's when None): compression (mm) =
    (F + its friction) / its spring rate (seagen.fit.predict), as a predictor of (enc, pot, force)."""

    def predict(enc: np.ndarray, pot: np.ndarray, force_n: np.ndarray) -> np.ndarray:
        return kinematics_predict("control", pd.DataFrame({"force_n": np.asarray(force_n, dtype=float)}), geo)

    return predict


def kinematic_cloud(
    latency_s: float = 0.1, refresh_hz: float = 10.0, geo: Geometry | None = None
) -> CloudPredictor:
    """The float kinematic inverse of the actuator `geo` (the paper's when None) off the MCU, refreshed at
    `refresh_hz` with `latency_s` delay."""
    return CloudPredictor(kinematic_float(geo), latency_s, refresh_hz)
