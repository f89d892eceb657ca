"""Fixed-point primitives, the Python twins of c_runtime/sea_fixed.c (same names, same integers).

All functions take and return numpy int64 arrays (or Python ints) and are exact: no float is involved
once the inputs are integers. Each docstring states range, rounding and saturation, as the C does.
"""

from __future__ import annotations

import numpy as np

from seagen.c_runtime import defines
from seagen.runtime.actq import ActQ

_H = defines("sea_fixed.h")  # the header is the one definition of the formats
COMP_FRAC_BITS = _H["SEA_COMP_FRAC_BITS"]  # compression: Q16 mm
FORCE_FRAC_BITS = _H["SEA_FORCE_FRAC_BITS"]  # desired force: Q16 N
LINK_TABLE_LEN = _H["SEA_LINK_TABLE_LEN"]
INT16_MIN, INT16_MAX = -(2**15), 2**15 - 1
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1


def rshift_rne(v: np.ndarray | int, s: int) -> np.ndarray:
    """Round(v / 2^s), ties to even, for int64 v and 0 <= s <= 62 (sea_rshift_rne_s64/_s32)."""
    v = np.asarray(v, dtype=np.int64)
    if s <= 0:
        return v
    q = v >> np.int64(s)
    r = v - (q << np.int64(s))
    half = np.int64(1) << np.int64(s - 1)
    return q + ((r > half) | ((r == half) & ((q & 1) == 1))).astype(np.int64)


def sat16(v: np.ndarray | int) -> np.ndarray:
    """Clamp to [INT16_MIN, INT16_MAX] (sea_sat16); returns int64 values in int16 range."""
    return np.clip(np.asarray(v, dtype=np.int64), INT16_MIN, INT16_MAX)


def sat32(v: np.ndarray | int) -> np.ndarray:
    """Clamp to the int32 range (sea_sat32)."""
    return np.clip(np.asarray(v, dtype=np.int64), INT32_MIN, INT32_MAX)


def linkage_q16(a: ActQ, pot: np.ndarray | int) -> np.ndarray:
    """Linkage term for pot clamped to 0..pot_max, interpolated and rounded half to even (sea_linkage_q16)."""
    p = np.clip(np.asarray(pot, dtype=np.int64), 0, a.pot_max)
    i = p >> a.link_shift
    f = p - (i << a.link_shift)
    table = a.table
    lo, hi = table[i], table[i + 1]
    return rshift_rne(lo * (1 << a.link_shift) + (hi - lo) * f, a.link_shift)


def compression_q16(a: ActQ, enc: np.ndarray | int, pot: np.ndarray | int) -> np.ndarray:
    """Spring compression in Q16 mm from raw counts, saturated to int32 (sea_compression_q16)."""
    travel = rshift_rne(np.asarray(enc, dtype=np.int64) * a.travel_q, a.travel_shift)
    return sat32(linkage_q16(a, pot) + travel)


def clamp(v: np.ndarray | int, lo: np.ndarray | int, hi: np.ndarray | int) -> np.ndarray:
    """Clamp v to [lo, hi], the result is lo when lo > hi (sea_clamp_s64)."""
    return np.maximum(np.minimum(np.asarray(v, dtype=np.int64), hi), lo)


def div_rne(num: np.ndarray | int, den: int) -> np.ndarray:
    """Round(num / den), ties to even, for den > 0; 0 when den <= 0 (sea_div_rne_s32)."""
    num = np.asarray(num, dtype=np.int64)
    if den <= 0:
        return np.zeros_like(num)
    q, r = np.divmod(num, np.int64(den))  # floor quotient, 0 <= r < den
    return q + ((2 * r > den) | ((2 * r == den) & ((q & 1) == 1))).astype(np.int64)
