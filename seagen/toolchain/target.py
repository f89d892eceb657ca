"""One build target interface: a generated model built with the batch driver; `infer`, `step`, `tick`.

Every target (the host through cffi, an emulated Cortex-M core) links the model's files with the same
driver (templates/driver.c.j2) and implements only `_call`: run one driver function on numpy buffers.
The model's facts (inputs, external arguments) come from the quantized IR, never from the header text.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from seagen import __version__
from seagen.codegen.runtime import CONTROL_RUNTIME, runtime_sources
from seagen.ir import QModel
from seagen.runtime.features import external_inputs, has_pipeline, is_predictor

# NAME_tick_batch's parameter words: the sea_control_config fields, in order, with their C types.
TICK_FIELDS = (
    *((f"pid.{f}", "int32_t") for f in ("kp", "ki", "kd", "d_alpha", "margin")),
    ("pid.out_min", "int32_t"),
    ("pid.out_max", "int32_t"),
    *((f, "int32_t") for f in ("predict_every", "pred_avg", "force_min", "force_max")),
    *((f, "int32_t") for f in ("enc_jump_max", "pot_stuck_ticks")),
)


def driver_sources(prefix: str, qm: QModel) -> dict[str, str]:
    """{NAME_driver.h, NAME_driver.c} (the batch entry points every target calls), and for a control
    predictor the controller runtime its NAME_tick_batch runs."""
    from seagen.codegen.render import environment

    tick = is_predictor(qm)
    ctx = {
        "P": prefix,
        "PU": prefix.upper(),
        "n_in": len(qm.inputs),
        "n_ext": len(external_inputs(qm)),
        "version": __version__,
        "tick_fields": TICK_FIELDS if tick else (),
        "pipeline": has_pipeline(qm),
    }
    env = environment()
    out = {f"{prefix}_driver{ext}": env.get_template(f"driver{ext}.j2").render(ctx) for ext in (".h", ".c")}
    return {**out, **(runtime_sources(*CONTROL_RUNTIME) if tick else {})}


def entry_points(prefix: str, qm: QModel) -> tuple[str, ...]:
    """The driver functions of `qm`: NAME_infer_batch, NAME_step_batch (+ NAME_tick_batch)."""
    fns = (
        "infer_batch",
        *(("step_batch",) if has_pipeline(qm) else ()),
        *(("tick_batch",) if is_predictor(qm) else ()),
    )
    return tuple(f"{prefix}_{f}" for f in fns)


class Target(ABC):
    """A generated model built for one target; `infer` and `step` run the driver's batch entry points."""

    def __init__(self, prefix: str, qm: QModel) -> None:
        self.prefix, self.qm = prefix, qm
        self.n_in, self.n_ext = len(qm.inputs), len(external_inputs(qm))

    @abstractmethod
    def _call(self, fn: str, *args: int | np.ndarray) -> list[np.ndarray]:
        """Call the driver function NAME_{fn}(args) (arrays by pointer); return the arrays afterwards."""

    def infer(self, x: np.ndarray) -> np.ndarray:
        """NAME_infer on each row of int16 features (N, n_in)."""
        x = np.ascontiguousarray(np.atleast_2d(x), dtype=np.int16)
        y = self._call("infer_batch", x, len(x), np.zeros(len(x), np.int16))[-1]
        return y.astype(np.int64)

    def step(
        self, enc: np.ndarray, pot: np.ndarray, trial: np.ndarray, ext: np.ndarray | None = None
    ) -> np.ndarray:
        """NAME_step over recorded samples (raw counts; ext: the quantized external inputs (N, n_ext)),
        NAME_reset at every trial start."""
        n, trial = len(enc), np.asarray(trial)
        reset = np.r_[True, trial[1:] != trial[:-1]].astype(np.uint8)[:n]
        e = np.zeros((n, max(self.n_ext, 1))) if ext is None else ext
        args = (
            np.ascontiguousarray(enc, dtype=np.int32),
            np.ascontiguousarray(pot, dtype=np.int32),
            np.ascontiguousarray(e, dtype=np.int16),
            reset,
            n,
            np.zeros(n, np.int16),
        )
        return self._call("step_batch", *args)[-1].astype(np.int64)

    def tick(
        self, config: dict[str, int], enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray
    ) -> np.ndarray:
        """Controller ticks of one actuator (sea_control_reset on the first sample, then sea_control_step
        per sample) with NAME_predict_q16 as its predictor; `config`: the TICK_FIELDS values. Motor mV."""
        if not is_predictor(self.qm):
            raise ValueError(f"{self.prefix} is not a control predictor: it has no controller tick")
        n = len(enc)
        args = (
            np.array([config[f] for f, _ in TICK_FIELDS], dtype=np.int32),
            np.ascontiguousarray(enc, dtype=np.int32),
            np.ascontiguousarray(pot, dtype=np.int32),
            np.ascontiguousarray(np.broadcast_to(force_q16, np.shape(enc)), dtype=np.int32),
            n,
            np.zeros(n, np.int32),
        )
        return self._call("tick_batch", *args)[-1].astype(np.int64)
