"""One build target interface: a generated model built with the batch driver, and `infer`/`step` on it.

Every target (the host through cffi, an emulated Cortex-M core) links the model's files with the same
driver (templates/driver.c.j2) and implements only `_call`: run one driver function on numpy buffers.
The model's facts (inputs, external arguments) come from the quantized IR, never from the header text.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from seagen import __version__
from seagen.ir import QModel
from seagen.quant.features import external_inputs


def driver_sources(prefix: str, qm: QModel) -> dict[str, str]:
    """{NAME_driver.h, NAME_driver.c}: the batch entry points every target calls."""
    from seagen.codegen.render import environment

    ctx = {
        "P": prefix,
        "PU": prefix.upper(),
        "n_in": len(qm.inputs),
        "n_ext": len(external_inputs(qm)),
        "version": __version__,
    }
    env = environment()
    return {f"{prefix}_driver{ext}": env.get_template(f"driver{ext}.j2").render(ctx) for ext in (".h", ".c")}


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
