"""Generated control predictors (generated/ctl_sf, ctl_mlp): per-tick integer twin and the float model."""

from __future__ import annotations

from functools import cache

import numpy as np

from seagen.control.controller import FORCE_FRAC
from seagen.demo import GENERATED
from seagen.plant import geometry as g
from seagen.quant import kernels as K
from seagen.quant import primitives as P
from seagen.quant.features import feature_plan
from seagen.reference import float_ref, numpy_ref

MODEL_FILES = {"ctl_sf": "sf_control.pt", "ctl_mlp": "mlp_control.pt"}


@cache
def export(prefix: str):
    """The in-memory export (float model, quantized IR) of the default control model `prefix`."""
    from seagen.codegen.export import prepare

    return prepare(str(GENERATED / "models" / MODEL_FILES[prefix]), prefix=prefix)


class StepTwin:
    """Twin of NAME_predict_q16 (NAME_step + scaling to Q16 mm) for a batch, one call per tick.

    State: the previous two values of (pot, enc, compression Q16) per actuator; the first call sees
    x[-1] = x[-2] = x[0] (seagen.data.features.differences), like NAME_reset + the `primed` flag.
    """

    def __init__(self, prefix: str) -> None:
        self.qm = export(prefix).qmodel
        self.plan = feature_plan(self.qm)
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
        cols = []
        for src in self.plan:
            if src.kind == "angle":
                v = pot * P.POT_DEG_Q24 + P.POT_OFFSET_Q24
            elif src.kind == "external":
                v = K.to_s16(force, FORCE_FRAC, src.to_frac)
            else:
                v = {"base": b, "d": d, "dd": dd}[src.kind][src.index]
            cols.append(K.to_s16(v, src.from_frac, src.to_frac))
        y = numpy_ref.infer(self.qm, np.stack(cols, axis=1))
        return P.sat32(np.asarray(y, np.int64) * (1 << (16 - self.qm.out_frac)))


def float_features(names: list[str], enc: np.ndarray, pot: np.ndarray, force_n: np.ndarray) -> np.ndarray:
    """Physical model inputs (n, n_in) from the last three samples (rows k-2, k-1, k) of enc and pot."""
    enc, pot = np.asarray(enc, float), np.asarray(pot, float)
    angle = g.angle_from_pot(pot)
    base = {"pot": pot, "enc": enc, "compression_mm": g.compression_mm(angle, enc), "angle_deg": angle}
    cols = []
    for name in names:
        if name == "force_n":
            cols.append(np.asarray(force_n, float))
        elif name.startswith("dd_"):
            x = base[name[3:]]
            cols.append(x[2] - 2 * x[1] + x[0])
        elif name.startswith("d_"):
            x = base[name[2:]]
            cols.append(x[2] - x[1])
        else:
            cols.append(base[name][2])
    return np.stack(cols, axis=1)


def float_predictor(prefix: str):
    """The float model of `prefix` as a CloudPredictor function: (enc rows, pot rows, force N) -> mm."""
    fm = export(prefix).float_model
    names = [s.name for s in fm.inputs]

    def fn(enc: np.ndarray, pot: np.ndarray, force_n: np.ndarray) -> np.ndarray:
        return float_ref.predict(fm, float_features(names, enc, pot, force_n))

    return fn
