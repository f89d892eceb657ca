"""The closed loop's `pil` controllers: a generated predictor and its controller as firmware on an emulated
board (seagen.pil), or for a cloud predictor the controller alone, its setpoint set over the link."""

from __future__ import annotations

from dataclasses import replace

from seagen.control.loop import CloudPredictor, McuPredictor
from seagen.errors import UserError
from seagen.pil.controller import PilController
from seagen.runtime.control import ControlConfig

CLOUD_SHELL = "ctl_sf"  # the export whose controller (without its predictor) serves the cloud link


def predictor_files(prefix: str, c: ControlConfig) -> dict[str, str]:
    """The generated predictor `prefix` (generated/), its controller rendered with `c`, and the runtime."""
    from seagen.codegen.controller import controller_files
    from seagen.codegen.runtime import runtime_sources
    from seagen.defaults import GENERATED
    from seagen.setups.shipped import export
    from seagen.toolchain.controller import generated_sources

    ctl = controller_files(prefix, export(prefix).qmodel, replace(c, predictor=None))
    return {**runtime_sources("sea_fixed.h", "sea_fixed.c"), **generated_sources(prefix, GENERATED), **ctl}


def loop_controller(core: str, pred: McuPredictor | CloudPredictor, c: ControlConfig) -> PilController:
    """The controller on an emulated board of `core` for a closed-loop predictor (a controller maker of
    seagen.control.loop with the core bound): a generated predictor on the board, or (a cloud predictor)
    the controller alone, its setpoint set over the link."""
    if isinstance(pred, McuPredictor):
        prefix = pred.c_symbol.removesuffix("_predict_q16")
        if prefix == pred.c_symbol:
            raise UserError(f"--impl pil runs generated predictors and the cloud link, not {pred.c_symbol}")
        return PilController(predictor_files(prefix, c), prefix, core)
    return PilController(predictor_files(CLOUD_SHELL, c), CLOUD_SHELL, core, onboard=False)
