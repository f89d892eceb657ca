"""Python twins of c_runtime/sea_nn.c (same names without the sea_ prefix; numpy int64, vectorized)."""

from __future__ import annotations

import numpy as np

from seagen.runtime.fixed import rshift_rne, sat16, sat32


def clamp_s16(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """sea_clamp_s16: each input clamped to its calibrated box."""
    return np.clip(np.asarray(x, dtype=np.int64), lo, hi)


def dense(w: np.ndarray, b: np.ndarray, x: np.ndarray, shift: int) -> np.ndarray:
    """sea_dense_*: sat16(rshift_rne(b + W x, shift)) for a batch x (N, n_in); exact in int64."""
    return sat16(rshift_rne(x @ w.T.astype(np.int64) + b.astype(np.int64)[None, :], shift))


def relu_s16(y: np.ndarray) -> np.ndarray:
    """sea_relu_s16."""
    return np.maximum(y, 0)


def leaky_s16(y: np.ndarray, alpha_q15: int) -> np.ndarray:
    """sea_leaky_s16: y < 0 -> sat16(rshift_rne(y * alpha_q15, 15))."""
    return np.where(y >= 0, y, sat16(rshift_rne(y * alpha_q15, 15)))


def hardtanh_s16(y: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """sea_hardtanh_s16."""
    return np.clip(y, lo, hi)


def table_s16(y: np.ndarray, table: np.ndarray, in_shift: int, offset: int) -> np.ndarray:
    """sea_table_s16: table[clamp(rshift_rne(y, in_shift) + offset, 0, len - 1)]."""
    return table[np.clip(rshift_rne(y, in_shift) + offset, 0, len(table) - 1)]


def horner_s32(x: np.ndarray, t: np.ndarray, add: np.ndarray | int, align: int, shift: int) -> np.ndarray:
    """sea_horner_s32: sat32(floor(x * t / 2^shift) + A), A = add * 2^align or floor(add / 2^-align)."""
    p = (np.asarray(x, dtype=np.int64) * np.asarray(t, dtype=np.int64)) >> np.int64(shift)
    a = np.asarray(add, dtype=np.int64)
    a = a * (np.int64(1) << np.int64(align)) if align >= 0 else a >> np.int64(-align)
    return sat32(p + a)


def to_s16(v: np.ndarray, from_frac: int, to_frac: int) -> np.ndarray:
    """sea_to_s16: Q(from_frac) -> int16 Q(to_frac), exact up-scaling or rounding shift, saturated."""
    v = np.asarray(v, dtype=np.int64)
    if to_frac >= from_frac:
        return sat16(v * (np.int64(1) << np.int64(to_frac - from_frac)))
    return sat16(rshift_rne(v, from_frac - to_frac))


def to_s32(v: np.ndarray, from_frac: int, to_frac: int) -> np.ndarray:
    """sea_to_s32: Q(from_frac) -> int32 Q(to_frac), exact up-scaling or rounding shift, saturated."""
    v = np.asarray(v, dtype=np.int64)
    if to_frac >= from_frac:
        return sat32(v * (np.int64(1) << np.int64(to_frac - from_frac)))
    return sat32(rshift_rne(v, from_frac - to_frac))
