"""The integer reference in numpy: the executable specification of the generated C (int64 arithmetic)."""

from __future__ import annotations

import numpy as np

from seagen.ir import QModel
from seagen.quant.activations import apply_table, leaky
from seagen.quant.primitives import rshift_rne, sat16, sat32


def clamp_inputs(qm: QModel, x: np.ndarray) -> np.ndarray:
    """Clamp every int16 input to its calibrated box [lo_q, hi_q] (the proof of no overflow needs it)."""
    lo = np.array([i.lo_q for i in qm.inputs], dtype=np.int64)
    hi = np.array([i.hi_q for i in qm.inputs], dtype=np.int64)
    return np.clip(np.asarray(x, dtype=np.int64), lo, hi)


def infer(qm: QModel, x: np.ndarray) -> np.ndarray:
    """NAME_infer on a batch: int16 features (N, n_in) -> int16 outputs (N,), as int64 arrays."""
    x = clamp_inputs(qm, np.atleast_2d(x))
    if qm.kind == "sf":
        return _sf(qm, x)
    tables = {t.name: t for t in qm.tables}
    for k, q in enumerate(qm.layers):
        acc = x @ q.w_q.T + q.b_q[None, :]
        y = sat16(rshift_rne(acc, q.shift))
        x = _activate(q.activation, q.act_params, tables.get(f"l{k}_{q.activation}"), y)
    return x[:, 0]


def _activate(act: str, params: tuple[int, ...], table, y: np.ndarray) -> np.ndarray:
    if act == "relu":
        return np.maximum(y, 0)
    if act == "leaky_relu":
        return leaky(y, params[0])
    if act == "hardtanh":
        return np.clip(y, params[0], params[1])
    if table is not None:
        return apply_table(table, y)
    return y


def _sf(qm: QModel, x: np.ndarray) -> np.ndarray:
    """Straight-line Horner program on registers (int32 values, int64 arithmetic)."""
    regs: dict[int, np.ndarray] = {}
    for op in qm.horner:
        if op.var < 0:
            regs[op.dst] = np.full(len(x), op.coef_q, dtype=np.int64)
            continue
        add = regs[op.add_reg] if op.add_reg >= 0 else np.int64(op.coef_q)
        acc = x[:, op.var] * regs[op.src] + add * (np.int64(1) << np.int64(op.align))
        regs[op.dst] = sat32(rshift_rne(acc, op.shift))
    return sat16(rshift_rne(regs[qm.horner[-1].dst], qm.out_shift))
