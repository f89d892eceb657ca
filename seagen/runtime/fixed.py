"""Fixed-point primitives, the Python twins of c_runtime/sea_fixed.c (same names, same integers).

All functions take and return numpy int64 arrays (or Python ints) and are exact: no float is involved
once the inputs are integers. Each docstring states range, rounding and saturation, as the C does.
"""

from __future__ import annotations

import numpy as np

from seagen import geometry as g
from seagen.c_runtime import defines

_H = defines("sea_fixed.h")  # the header is the one definition of the geometry constants
COMP_FRAC_BITS = _H["SEA_COMP_FRAC_BITS"]  # compression: Q16 mm
FORCE_FRAC_BITS = _H["SEA_FORCE_FRAC_BITS"]  # desired force: Q16 N
LINK_TABLE_SHIFT = _H["SEA_LINK_TABLE_SHIFT"]
LINK_TABLE_LEN = _H["SEA_LINK_TABLE_LEN"]
MM_PER_COUNT_Q24 = _H["SEA_MM_PER_COUNT_Q24"]  # Eq. 3, round(0.00438596 * 2^24)
POT_MAX = _H["SEA_POT_MAX"]
POT_DEG_Q24 = _H["SEA_POT_DEG_Q24"]  # Eq. 5, round(53.12195 / 4096 * 2^24)
POT_OFFSET_Q24 = _H["SEA_POT_OFFSET_Q24"]  # Eq. 5, -5 deg
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


def linkage_table_q16(
    cb_mm: float = g.CB_MM, ce_mm: float = g.CE_MM, de_home_mm: float = g.DE_HOME_MM
) -> np.ndarray:
    """Q16 mm table of cos(angle(pot)) * CB - (DE_home - CE) at pot = 16 i, i = 0..256 (Eq. 2, 5)."""
    pot = np.arange(LINK_TABLE_LEN, dtype=float) * (1 << LINK_TABLE_SHIFT)
    angle = pot * g.POT_DEG_PER_COUNT + g.POT_OFFSET_DEG
    mm = np.cos(np.radians(angle)) * cb_mm - (de_home_mm - ce_mm)
    return np.rint(mm * (1 << COMP_FRAC_BITS)).astype(np.int64)


def linkage_q16(table: np.ndarray, pot: np.ndarray | int) -> np.ndarray:
    """Linkage term for pot clamped to 0..4095, interpolated and rounded half to even (sea_linkage_q16)."""
    p = np.clip(np.asarray(pot, dtype=np.int64), 0, POT_MAX)
    i = p >> LINK_TABLE_SHIFT
    f = p - (i << LINK_TABLE_SHIFT)
    a = table[i].astype(np.int64)
    b = table[i + 1].astype(np.int64)
    return rshift_rne(a * (1 << LINK_TABLE_SHIFT) + (b - a) * f, LINK_TABLE_SHIFT)


def compression_q16(table: np.ndarray, enc: np.ndarray | int, pot: np.ndarray | int) -> np.ndarray:
    """Spring compression in Q16 mm from raw counts, saturated to int32 (sea_compression_q16)."""
    travel = rshift_rne(np.asarray(enc, dtype=np.int64) * MM_PER_COUNT_Q24, 24 - COMP_FRAC_BITS)
    return sat32(linkage_q16(table, pot) + travel)


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
