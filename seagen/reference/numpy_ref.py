"""The integer reference in numpy: the executable specification of the generated C (int64 arithmetic)."""

from __future__ import annotations

import numpy as np

from seagen.ir import QSF, QLayer, QModel, QTable
from seagen.quant.activation import ADDED, apply
from seagen.runtime import nn as K


def clamp_inputs(qm: QModel, x: np.ndarray) -> np.ndarray:
    """Clamp every int16 input to its calibrated box [lo_q, hi_q] (the no-overflow proof needs it)."""
    lo = np.array([i.lo_q for i in qm.inputs], dtype=np.int64)
    hi = np.array([i.hi_q for i in qm.inputs], dtype=np.int64)
    return K.clamp_s16(np.atleast_2d(x), lo, hi)


def activate(q: QLayer, table: QTable | None, y: np.ndarray) -> np.ndarray:
    """The layer's activation on int16 values."""
    if q.activation == "relu":
        return K.relu_s16(y)
    if q.activation == "leaky_relu":
        return K.leaky_s16(y, q.act_params[0])
    if q.activation == "hardtanh":
        return K.hardtanh_s16(y, q.act_params[0], q.act_params[1])
    if q.activation in ADDED:
        return apply(q, table, y)
    if table is not None:
        return K.table_s16(y, table.values, table.in_shift, table.offset)
    return y


def infer(qm: QModel, x: np.ndarray) -> np.ndarray:
    """NAME_infer on a batch: int16 features (N, n_in) -> int16 outputs (N,), as int64 arrays."""
    x = clamp_inputs(qm, x)
    if isinstance(qm, QSF):
        return _sf(qm, x)
    tables = {t.name: t for t in qm.tables}
    for k, q in enumerate(qm.layers):
        x = activate(q, tables.get(f"l{k}_{q.activation}"), K.dense(q.w_q, q.b_q, x, q.shift))
    return x[:, 0]


def _sf(qm: QSF, x: np.ndarray) -> np.ndarray:
    """The straight-line Horner program on int32 registers."""
    regs: dict[int, np.ndarray] = {}
    for op in qm.horner:
        if op.var < 0:
            regs[op.dst] = np.full(len(x), op.coef_q, dtype=np.int64)
        else:
            add = regs[op.add_reg] if op.add_reg >= 0 else op.coef_q
            regs[op.dst] = K.horner_s32(x[:, op.var], regs[op.src], add, op.align, op.shift)
    return K.to_s16(regs[qm.horner[-1].dst], qm.out_shift, 0)
