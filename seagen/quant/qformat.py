"""Q-format choice: the largest number of fractional bits that keeps a magnitude inside a word."""

from __future__ import annotations

import math

import numpy as np

INPUT_MARGIN = 0.125  # the calibrated box is widened by this fraction of its span on each side
MIN_FRAC, MAX_FRAC = -16, 30


def frac_for(maxabs: float, limit: int) -> int:
    """Largest f in [MIN_FRAC, MAX_FRAC] with round(maxabs * 2^f) <= limit (limit = 32767, 127, 2^30...)."""
    if not math.isfinite(maxabs):
        raise ValueError("magnitude is not finite")
    if maxabs <= 0:
        return MAX_FRAC
    f = math.floor(math.log2(limit / maxabs))
    while f > MIN_FRAC and round(maxabs * 2.0**f) > limit:
        f -= 1
    while f < MAX_FRAC and round(maxabs * 2.0 ** (f + 1)) <= limit:
        f += 1
    return max(MIN_FRAC, min(MAX_FRAC, f))


SATURATE = 2.0**62  # quantize() saturates here: the callers' range checks refuse such values


def quantize(x: np.ndarray | float, frac: int) -> np.ndarray:
    """round(x * 2^frac) half to even, as int64 (exact for |x * 2^frac| < 2^53); beyond +-2^62 it saturates
    (no undefined float -> int64 cast) and the caller's range check refuses the value."""
    with np.errstate(over="ignore"):  # an overflow to +-inf saturates like any value beyond 2^62
        y = np.rint(np.asarray(x, dtype=float) * 2.0**frac)
    return np.clip(y, -SATURATE, SATURATE).astype(np.int64)


def widened(lo: float, hi: float, margin: float = INPUT_MARGIN) -> tuple[float, float]:
    """The calibrated range widened by `margin` of its span on each side (at least 1e-6 wide)."""
    span = max(hi - lo, 1e-6)
    return lo - margin * span, hi + margin * span


def widened_box(signals) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) arrays of the widened calibrated box of Signals (where the bounds are proven)."""
    lo, hi = np.array([widened(s.lo, s.hi) for s in signals], dtype=float).T
    return lo, hi
