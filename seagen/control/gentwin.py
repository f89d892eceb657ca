"""Generated control predictors (generated/ctl_sf, ctl_mlp): per-tick integer twin and the float model."""

from __future__ import annotations

from functools import cache

import numpy as np
import pandas as pd

from seagen.control.controller import FORCE_FRAC
from seagen.data.features import derive
from seagen.demo import DEFAULT_PREFIX, GENERATED
from seagen.quant import kernels as K
from seagen.quant import primitives as P
from seagen.quant.features import EXTERNAL, model_inputs
from seagen.reference import float_ref, numpy_ref

MODEL_FILES = {prefix: f"{name}.pt" for name, prefix in DEFAULT_PREFIX.items()}  # prefix -> model file


@cache
def export(prefix: str):
    """The in-memory export (float model, quantized IR) of the default control model `prefix`."""
    from seagen.export import prepare

    return prepare(str(GENERATED / "models" / MODEL_FILES[prefix]), prefix=prefix)


class StepTwin:
    """Twin of NAME_predict_q16 (NAME_step + scaling to Q16 mm) for a batch, one call per tick.

    State: the previous two values of (pot, enc, compression Q16) per actuator; the first call sees
    x[-1] = x[-2] = x[0] (seagen.data.features.differences), like NAME_reset + the `primed` flag.
    """

    def __init__(self, prefix: str) -> None:
        self.qm = export(prefix).qmodel
        self.table = P.linkage_table_q16()
        self.p1: np.ndarray | None = None
        self.p2: np.ndarray | None = None

    def __call__(self, enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
        """Desired compression (Q16 mm, int64) for raw counts and the desired force (Q16 N)."""
        enc, pot = np.asarray(enc, np.int64), np.asarray(pot, np.int64)
        b = np.stack([pot, enc, P.compression_q16(self.table, enc, pot)])
        if self.p1 is None or self.p2 is None:
            self.p1, self.p2 = b.copy(), b.copy()
        d, dd = b - self.p1, b - 2 * self.p1 + self.p2
        self.p2, self.p1 = self.p1, b
        force = np.broadcast_to(np.asarray(force_q16, np.int64), enc.shape)
        ext = [K.to_s16(force, FORCE_FRAC, q.frac) for q in self.qm.inputs if q.signal.name in EXTERNAL]
        x = model_inputs(self.qm, b, d, dd, np.stack(ext, axis=1) if ext else None)
        y = numpy_ref.infer(self.qm, x)
        return P.sat32(np.asarray(y, np.int64) * (1 << (16 - self.qm.out_frac)))


def float_features(names: list[str], enc: np.ndarray, pot: np.ndarray, force_n: np.ndarray) -> np.ndarray:
    """Physical model inputs (n, n_in) from the last three samples (rows k-2, k-1, k) of enc and pot,
    computed by the one feature function (seagen.data.features.derive), one trial per actuator."""
    n = np.shape(enc)[1]
    rows = pd.DataFrame({"trial": np.tile(np.arange(n), 3), "enc": np.ravel(enc), "pot": np.ravel(pot)})
    last = derive(rows.sort_values("trial", kind="stable")).groupby("trial").tail(1)
    return last.assign(force_n=np.asarray(force_n, float))[names].to_numpy(dtype=float)


def float_predictor(prefix: str):
    """The float model of `prefix` as a CloudPredictor function: (enc rows, pot rows, force N) -> mm."""
    fm = export(prefix).float_model
    names = [s.name for s in fm.inputs]

    def fn(enc: np.ndarray, pot: np.ndarray, force_n: np.ndarray) -> np.ndarray:
        return float_ref.predict(fm, float_features(names, enc, pot, force_n))

    return fn
