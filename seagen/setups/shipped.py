"""The shipped control models (generated/models: ctl_sf, ctl_mlp) as the closed loop's predictors, and the
experiment's configurations that run them (paper Table II) beside the model-free baseline."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

from seagen.control.experiment import Setup
from seagen.control.link import BleLink, cloud_control
from seagen.control.loop import CloudPredictor, McuPredictor
from seagen.control.predictors import kinematic_mcu
from seagen.defaults import DEFAULT_PREFIX, GENERATED
from seagen.ir import FloatModel, QModel
from seagen.runtime.control import MLP_PRED_AVG, ControlConfig

MODEL_FILES = {prefix: f"{name}.pt" for name, prefix in DEFAULT_PREFIX.items()}  # prefix -> model file


@dataclass(frozen=True)
class DefaultModel:
    """The float and quantized IR of one default control model."""

    float_model: FloatModel
    qmodel: QModel


@cache
def export(prefix: str) -> DefaultModel:
    """The float model and quantized IR of the default control model `prefix` (what its export holds)."""
    from seagen.frontends.load import load_float_model
    from seagen.quant.model import quantize

    fm = load_float_model(str(GENERATED / "models" / MODEL_FILES[prefix]))
    return DefaultModel(fm, quantize(fm))


def float_predictor(prefix: str):
    """The float model of `prefix` as a CloudPredictor function: (enc rows, pot rows, force N) -> mm."""
    from seagen.actuator import default_actuator
    from seagen.control import gentwin
    from seagen.geometry import geometry

    # the shipped models were trained on the paper's actuator
    return gentwin.float_predictor(export(prefix).float_model, geometry(default_actuator()))


def generated_mcu(prefix: str, predict_every: int = 1) -> McuPredictor:
    """The generated fixed-point predictor `prefix` (generated/PREFIX.c, via cffi) with its per-tick twin.

    Its feature pipeline differences consecutive calls, so it is meant to be called at the training rate
    (the description's loop rate); at predict_every > 1 its d_/dd_ inputs are predict_every times the
    trained scale.
    """
    from seagen.control.gentwin import StepTwin
    from seagen.toolchain.controller import generated_cdef, generated_ctx, generated_sources

    return McuPredictor(
        f"{prefix}_predict_q16",
        generated_ctx(prefix),
        lambda: StepTwin(prefix, export(prefix).qmodel),
        predict_every,
        generated_cdef(prefix, GENERATED),
        generated_sources(prefix, GENERATED),
        stateful=True,
    )


def generated_cloud(prefix: str, link: BleLink | None = None) -> CloudPredictor:
    """The float model behind `prefix` on the PC (the paper's set-up), over the Bluetooth LE link `link`
    (the sourced defaults when None) in 10 Hz rounds (paper §VI)."""
    return CloudPredictor(float_predictor(prefix), refresh_hz=10.0, link=link or BleLink())


@cache
def paper_cloud_control() -> ControlConfig:
    """The MCU's controller of the paper's cloud set-up: the paper's actuator with its 0.1 mm margin."""
    from seagen.actuator import default_actuator
    from seagen.runtime.actq import act_q

    act = default_actuator()
    return cloud_control(act_q(act), act.stiffness_n_per_mm, act.stiffness_n_per_mm)


# Configuration name -> factory() of its predictor and controller configuration (Table II rows). The
# cloud's link is its own (seagen.control.link: `seagen simulate`'s --latency and --link-* replace it).
CONFIGS: dict[str, Callable[[], Setup]] = {
    "sf_mcu": lambda: (generated_mcu("ctl_sf"), ControlConfig()),
    "mlp_cloud": lambda: (generated_cloud("ctl_mlp"), paper_cloud_control()),
    "mlp_mcu": lambda: (generated_mcu("ctl_mlp"), ControlConfig(pred_avg=MLP_PRED_AVG)),
    "kin_mcu": lambda: (kinematic_mcu(predict_every=1), ControlConfig()),  # baseline
}
# Configurations running a shipped model (trained for the paper's actuator): name -> that model's default:NAME
NEEDS_SHIPPED = {"sf_mcu": "sf_control", "mlp_cloud": "mlp_control", "mlp_mcu": "mlp_control"}
MODEL_FREE = tuple(n for n in CONFIGS if n not in NEEDS_SHIPPED)  # run on any described actuator
