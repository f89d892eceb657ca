"""The torch twin of the integer reference: the same program on int64 tensors (no torch.ao)."""

from __future__ import annotations

import numpy as np
import torch

from seagen.ir import QSF, QModel
from seagen.runtime.activations import HSIG_FRAC, PRELU_FRAC, SLOPE_FRAC, SMOOTH, TABLE_OUT_FRAC

I16_MIN, I16_MAX = -(2**15), 2**15 - 1
I32_MIN, I32_MAX = -(2**31), 2**31 - 1


def rshift_rne(v: torch.Tensor, s: int) -> torch.Tensor:
    """Round(v / 2^s) half to even on int64 tensors (twin of sea_rshift_rne_s64)."""
    if s <= 0:
        return v
    q = v >> s
    r = v - (q << s)
    half = 1 << (s - 1)
    return q + ((r > half) | ((r == half) & ((q & 1) == 1))).long()


def _activate(
    act: str, params: tuple[int, ...], table: torch.Tensor | None, shift_off: tuple[int, int], y: torch.Tensor
) -> torch.Tensor:
    if act == "relu":
        return y.clamp(min=0)
    if act == "leaky_relu":
        return torch.where(y >= 0, y, rshift_rne(y * params[0], 15))
    if act == "hardtanh":
        return y.clamp(params[0], params[1])
    if act in SMOOTH:  # s relu(y) + g[idx] (seagen/runtime/activations.py smooth_s16)
        assert table is not None
        idx = (rshift_rne(y, shift_off[0]) + shift_off[1]).clamp(0, table.numel() - 1)
        return (rshift_rne(y.clamp(min=0) * params[0], SLOPE_FRAC) + table[idx]).clamp(I16_MIN, I16_MAX)
    if act in ("hardsigmoid", "hardswish"):
        h = rshift_rne(y * params[0] + params[1], HSIG_FRAC - TABLE_OUT_FRAC).clamp(0, 1 << TABLE_OUT_FRAC)
        return h if act == "hardsigmoid" else rshift_rne(y * h, TABLE_OUT_FRAC).clamp(I16_MIN, I16_MAX)
    if act == "prelu":
        a = torch.tensor(params, dtype=torch.int64)[None, :]
        return torch.where(y >= 0, y, rshift_rne(y * a, PRELU_FRAC).clamp(I16_MIN, I16_MAX))
    if table is not None:
        idx = (rshift_rne(y, shift_off[0]) + shift_off[1]).clamp(0, table.numel() - 1)
        return table[idx]
    return y


def infer(qm: QModel, x: np.ndarray) -> np.ndarray:
    """NAME_infer on a batch of int16 features (N, n_in) -> (N,) int64 numpy array."""
    t = torch.as_tensor(np.atleast_2d(np.asarray(x, dtype=np.int64)))
    lo = torch.tensor([i.lo_q for i in qm.inputs], dtype=torch.int64)
    hi = torch.tensor([i.hi_q for i in qm.inputs], dtype=torch.int64)
    t = torch.maximum(torch.minimum(t, hi), lo)
    if isinstance(qm, QSF):
        return _sf(qm, t).numpy()
    tables = {tb.name: tb for tb in qm.tables}
    for k, q in enumerate(qm.layers):
        w = torch.as_tensor(q.w_q.astype(np.int64))
        b = torch.as_tensor(q.b_q.astype(np.int64))
        y = rshift_rne(t @ w.T + b, q.shift).clamp(I16_MIN, I16_MAX)
        tb = tables.get(f"l{k}_{q.activation}")
        vals = torch.as_tensor(tb.values) if tb is not None else None
        t = _activate(q.activation, q.act_params, vals, (tb.in_shift, tb.offset) if tb else (0, 0), y)
    return t[:, 0].numpy()


def _sf(qm: QSF, x: torch.Tensor) -> torch.Tensor:
    regs: dict[int, torch.Tensor] = {}
    for op in qm.horner:
        if op.var < 0:
            regs[op.dst] = torch.full((x.shape[0],), op.coef_q, dtype=torch.int64)
            continue
        add = regs[op.add_reg] if op.add_reg >= 0 else torch.tensor(op.coef_q, dtype=torch.int64)
        add = add * (1 << op.align) if op.align >= 0 else add >> -op.align
        regs[op.dst] = (((x[:, op.var] * regs[op.src]) >> op.shift) + add).clamp(I32_MIN, I32_MAX)
    return rshift_rne(regs[qm.horner[-1].dst], qm.out_shift).clamp(I16_MIN, I16_MAX)
