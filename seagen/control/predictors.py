"""Predictors available to the closed loop: the kinematic inverse and the generated SF/MLP models."""

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


def generated_mcu(prefix: str, predict_every: int = 1) -> McuPredictor:
    """The generated fixed-point predictor `prefix` (generated/PREFIX.c, via cffi) with its per-tick twin.

    Its feature pipeline differences consecutive calls, so it is meant to be called at the training rate
    (the description's loop rate); at predict_every > 1 its d_/dd_ inputs are predict_every times the
    trained scale.
    """
    from seagen.control.gentwin import StepTwin
    from seagen.defaults import GENERATED
    from seagen.toolchain.controller import generated_cdef, generated_ctx, generated_sources

    return McuPredictor(
        f"{prefix}_predict_q16",
        generated_ctx(prefix),
        lambda: StepTwin(prefix),
        predict_every,
        generated_cdef(prefix, GENERATED),
        generated_sources(prefix, GENERATED),
        stateful=True,
    )


def generated_cloud(prefix: str, latency_s: float = 0.1, refresh_hz: float = 10.0) -> CloudPredictor:
    """The float model behind `prefix` off the MCU (the paper's set-up), over the Bluetooth link."""
    from seagen.control.gentwin import float_predictor

    return CloudPredictor(float_predictor(prefix), latency_s, refresh_hz)
