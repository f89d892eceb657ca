"""The paper's experiment on a user's own models: a control model exported to C (the MCU set-up) and as its
float model behind the Bluetooth link (the cloud set-up); a calibration model, if given, estimates the force
from the recorded sensors of every run, as the glove's firmware would."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from seagen.control.loop import CloudPredictor, McuPredictor
from seagen.errors import UserError
from seagen.runtime.control import ControlConfig

Setup = tuple[McuPredictor | CloudPredictor, ControlConfig]


@dataclass
class Exported:
    """A model file as `seagen export` would write it, in memory: float and quantized IR, the C files."""

    float_model: Any
    qmodel: Any
    prefix: str
    files: dict[str, str]
    act: Any = None  # the actuator's constants (seagen.runtime.actq.ActQ) the C was rendered for
    actuator: Any = None  # its description (seagen.actuator.Actuator)


def exported(
    model: str, features: str | None = None, allow_pickle: bool = False, given: Any = None
) -> Exported:
    """MODEL read, quantized, checked against its original by the oracle (CheckFailed beyond the bound) and
    rendered to C: the in-memory core of `seagen export` (no manifest, nothing written). A `given` actuator
    (seagen.actuator.Actuator) the model file's recorded one disagrees with is refused (exit 2)."""
    from seagen.cnames import assert_valid_prefix
    from seagen.codegen.actfile import export_actuator
    from seagen.codegen.render import RUNTIME, render
    from seagen.codegen.runtime import runtime_sources
    from seagen.defaults import model_label
    from seagen.errors import CheckFailed
    from seagen.frontends.load import load_with_original, read_features_file
    from seagen.quant.model import quantize
    from seagen.reference.oracle import box_points, compare_original
    from seagen.runtime.actq import act_q

    loaded = load_with_original(model, read_features_file(features), None, allow_pickle)
    act = export_actuator(loaded, given, model_label(model))  # the model file's (the paper's if none)
    qm = quantize(loaded.model)
    rep = compare_original(
        f"oracle ({loaded.runtime}) on the box", qm, loaded.original, box_points(qm), loaded.margin
    )
    if not rep.ok:
        raise CheckFailed(f"{model}: {rep.line()}")
    prefix = assert_valid_prefix(prefix_of(model))
    aq = act_q(act)
    files = {**render(qm, prefix, act=aq), **runtime_sources(*RUNTIME)}
    return Exported(loaded.model, qm, prefix, files, aq, act)


def prefix_of(model: str) -> str:
    """The C prefix of a model file's in-memory export (and of its NAME_mcu / NAME_cloud configurations)."""
    stem = re.sub(r"[^A-Za-z0-9_]", "_", Path(model).stem)
    return stem if stem[:1].isalpha() and not stem.startswith("sea") else f"m_{stem}"


def control_setups(
    model: str, features: str | None = None, allow_pickle: bool = False, given: Any = None
) -> tuple[dict[str, Callable[[], Setup]], str]:
    """{NAME_mcu, NAME_cloud: factory() -> (predictor, controller configuration)} for a control
    model file, and the paper's row (SF or MLP) its kind compares with; `given`: the simulated actuator
    (a bare network's; a model file recording another is refused)."""
    from seagen.actuator import default_actuator
    from seagen.codegen.controller import shipped_config
    from seagen.codegen.runtime import cdef_of, runtime_sources
    from seagen.control.gentwin import StepTwin, float_predictor
    from seagen.control.link import BleLink, cloud_control
    from seagen.geometry import geometry
    from seagen.ir import QMLP
    from seagen.runtime.features import has_pipeline, is_predictor
    from seagen.toolchain.controller import NN_SOURCES, generated_ctx

    ex = exported(model, features, allow_pickle, given)
    qm, p = ex.qmodel, ex.prefix
    if not is_predictor(qm) or not has_pipeline(qm):
        raise UserError(
            f"{model}: --model needs a control model (desired force + sensor features -> compression_mm, "
            f"e.g. seagen train --task control), not one computing {qm.output.name}"
        )
    cdef = cdef_of(*runtime_sources("sea_features.h").values(), ex.files[f"{p}.h"])
    sources = {**runtime_sources(*NN_SOURCES), f"{p}.h": ex.files[f"{p}.h"], f"{p}.c": ex.files[f"{p}.c"]}
    sources |= {n: t for n, t in ex.files.items() if n.startswith("sea_act_")}
    cfg = shipped_config(qm, ex.act)
    cloud_fn = float_predictor(ex.float_model, geometry(ex.actuator))  # features on the model's own actuator

    def mcu() -> Setup:
        pred = McuPredictor(
            f"{p}_predict_q16",
            generated_ctx(p),
            lambda: StepTwin(p, qm, ex.act),
            1,
            cdef,
            sources,
            stateful=True,
        )
        return pred, cfg

    def cloud() -> Setup:  # the paper's set-up: the link's defaults, its 0.1 mm margin
        stiffness = (ex.actuator or default_actuator()).stiffness_n_per_mm
        ctl = cloud_control(ex.act, stiffness, default_actuator().stiffness_n_per_mm)
        return CloudPredictor(cloud_fn, refresh_hz=10.0, link=BleLink()), ctl

    return {f"{p}_mcu": mcu, f"{p}_cloud": cloud}, "MLP" if isinstance(qm, QMLP) else "SF"


@dataclass
class ForceEstimator:
    """A calibration model's export run as NAME_step (host C) over each actuator's recorded sensors."""

    prefix: str
    target: Any  # a seagen.toolchain.target.Target
    out_frac: int

    def __call__(self, rec: dict[str, np.ndarray]) -> np.ndarray:
        """Estimated force (N), ticks x actuators, from the enc/pot the controller saw."""
        enc, pot = rec["enc"].T.ravel(), rec["pot"].T.ravel()
        n_ticks, n_act = rec["enc"].shape
        trial = np.repeat(np.arange(n_act), n_ticks)
        out = np.asarray(self.target.step(enc, pot, trial), dtype=np.float64)
        return np.asarray(out * 2.0**-self.out_frac).reshape(n_act, n_ticks).T


def force_estimator(model: str, allow_pickle: bool = False, act: Any = None) -> ForceEstimator:
    """The calibration model's C (exported in memory, built for the host) as a force estimator; a model
    trained for another actuator than the simulated one `act` is refused (exit 2), before the oracle runs."""
    from seagen.runtime.features import external_inputs, has_pipeline
    from seagen.toolchain.model import CModel

    ex = exported(model, allow_pickle=allow_pickle, given=act)
    qm = ex.qmodel
    if qm.output.name != "force_n" or not has_pipeline(qm) or external_inputs(qm):
        raise UserError(
            f"{model}: --calibration needs a calibration model (sensor features -> force_n, e.g. seagen "
            f"train --task calibration), not one computing {qm.output.name}"
        )
    return ForceEstimator(ex.prefix, CModel(ex.files, ex.prefix, qm), qm.out_frac)
