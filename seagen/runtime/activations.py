"""Integer activations shared by every reference: exact ReLU/LeakyReLU/Hardtanh/PReLU, tables for tanh and
sigmoid, relu + bounded-correction tables for the smooth ones (ELU, SELU, Softplus, GELU, Mish, SiLU), integer
HardSigmoid/HardSwish; each with its worst error, the one the proven bound adds (seagen/quant/bound.py).

The smooth functions are unbounded on one side, so a table of f itself over a layer's proven input range
would grow with that range. Each is instead s * relu(x) + g(x) with g bounded and settling to a constant at
both tails (exponentially, or faster for GELU): the integer form is the exact (s = 1) or rounded s * relu(x)
plus a nearest-sample table of g, in the layer's own Q format, over the layer's proven input range cut to
[-R, R], R the radius where g is within a quarter table step of its limit. The table's length is bounded by
the function (2R / step + 1) whatever the range, and an input beyond its ends takes the end sample.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from seagen import fmath
from seagen.c_runtime import defines
from seagen.ir import QTable
from seagen.runtime.fixed import rshift_rne, sat16

_H = defines("sea_nn.h")  # the formats' one definition
TABLE_OUT_FRAC = _H["SEA_ACT_OUT_FRAC"]  # tanh/sigmoid/hardsigmoid outputs are Q14 (1.0 = 16384)
assert _H["SEA_ACT_ONE"] == 1 << TABLE_OUT_FRAC and _H["SEA_ACT_SLOPE_ONE"] == 1 << _H["SEA_ACT_SLOPE_FRAC"]
TABLE_STEP_FRAC = 8  # tables sampled every 2^-8 of the input (every input LSB when coarser)
TABLE_RANGE = {"tanh": 4.0, "sigmoid": 8.0}  # beyond +-R the function is taken as saturated
SMOOTH = ("elu", "selu", "softplus", "gelu", "gelu_tanh", "mish", "silu")  # s * relu(x) + table of g
SLOPE_FRAC = _H["SEA_ACT_SLOPE_FRAC"]  # s in Q14 (s = 1 exactly: 16384)
HSIG_FRAC = _H["SEA_ACT_HSIG_FRAC"]  # hardsigmoid's alpha x + beta summed in Q30 (int64), then rounded to Q14
PRELU_FRAC = _H["SEA_ACT_PRELU_FRAC"]  # PReLU slopes in Q15
GRID_FRAC = 10  # the grid (2^-10) on which sup |g'| and sup |f'| are measured
SELU = (1.6732632423543772, 1.0507009873554805)  # torch's and ONNX's alpha, scale
HARDSWISH = (1.0 / 6.0, 0.5)  # HardSwish(x) = x * HardSigmoid(x; 1/6, 1/2) (torch and ONNX)


def _f(name: str, x: np.ndarray) -> np.ndarray:
    return fmath.tanh(x) if name == "tanh" else 1.0 / (1.0 + fmath.exp(-x))


def make_table(name: str, in_frac: int, label: str) -> QTable:
    """Nearest-sample table of tanh or sigmoid for inputs in Q(in_frac)."""
    in_shift = max(in_frac - TABLE_STEP_FRAC, 0)
    step = 2.0 ** (in_shift - in_frac)
    offset = int(round(TABLE_RANGE[name] / step))
    x = (np.arange(2 * offset + 1) - offset) * step
    values = np.rint(_f(name, x) * 2**TABLE_OUT_FRAC).astype(np.int64)
    return QTable(label, values, in_frac, TABLE_OUT_FRAC, in_shift, offset)


def table_error(t: QTable, name: str) -> float:
    """Worst |table(x) - f(x)| (output units) for any x: half a step x Lipschitz + rounding, or tail."""
    step = 2.0 ** (t.in_shift - t.in_frac)
    lip = 1.0 if name == "tanh" else 0.25
    r = TABLE_RANGE[name]
    tail = 1.0 - fmath.tanh(r) if name == "tanh" else 1.0 / (1.0 + fmath.exp(r))
    return max(lip * step / 2, tail) + 2.0 ** -(TABLE_OUT_FRAC + 1)


# ---- the smooth ones: f = s relu(x) + g(x) -------------------------------------------------------------


def _vec(fn: Callable[[float], float]) -> Callable[[np.ndarray], np.ndarray]:
    """An element-by-element float function through the C library (the same bits on every CPU: fmath)."""
    return lambda x: np.array([fn(float(v)) for v in np.ravel(x)]).reshape(np.shape(x))


def _sig(v: float) -> float:
    return 1.0 / (1.0 + math.exp(-v)) if v >= 0 else math.exp(v) / (1.0 + math.exp(v))


def _g_scalar(name: str, p: tuple[float, ...], x: float) -> float:
    """g(x) = f(x) - s relu(x), written so that it keeps its digits at both tails."""
    a = abs(x)
    if name == "elu":
        return p[0] * math.expm1(x) if x < 0 else 0.0
    if name == "selu":
        return p[1] * p[0] * math.expm1(x) if x < 0 else 0.0
    if name == "softplus":  # torch: x where beta x > threshold
        return 0.0 if p[0] * x > p[1] else math.log1p(math.exp(-p[0] * a)) / p[0]
    if name == "gelu":
        return -0.5 * a * math.erfc(a / math.sqrt(2.0))
    if name == "gelu_tanh":
        u = math.sqrt(2.0 / math.pi) * (a + 0.044715 * a**3)
        return -a * _sig(-2.0 * u)
    if name == "silu":
        return -a * _sig(-a)
    if name == "mish":
        if x > 0:  # -2x / (1 + (1 + e^x)^2), without overflow
            e = math.exp(-x)
            return -2.0 * x * e * e / (e * e + (1.0 + e) ** 2)
        e = math.exp(x)
        return x * (e * e + 2 * e) / (e * e + 2 * e + 2)
    raise ValueError(name)


def slope(name: str, p: tuple[float, ...]) -> float:
    """s of f = s relu(x) + g(x): SELU's scale, 1 for the others."""
    return p[1] if name == "selu" else 1.0


def limits(name: str, p: tuple[float, ...]) -> tuple[float, float]:
    """g(-inf), g(+inf)."""
    if name == "elu":
        return -p[0], 0.0
    if name == "selu":
        return -p[1] * p[0], 0.0
    return 0.0, 0.0


def _curvature(name: str, p: tuple[float, ...]) -> float:
    """An upper bound on |g''| away from 0 (where ELU/SELU's g has a kink, its one-sided slopes are finite):
    ELU alpha e^x <= |alpha|, SELU scale alpha, Softplus beta sigma (1 - sigma) <= beta / 4, GELU
    phi(x)|2 - x^2| <= 0.8, SiLU <= 0.5, Mish <= 0.7, tanh-GELU < 0.9: 1 for the last four."""
    if name == "elu":
        return abs(p[0])
    if name == "selu":
        return p[1] * p[0]
    if name == "softplus":
        return p[0] / 4
    return 1.0


def smooth_g(name: str, p: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    """g on an array (float64, C library functions element by element)."""
    return _vec(lambda v: _g_scalar(name, p, v))(np.asarray(x, dtype=float))


def act_float(name: str, p: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    """The float activation (the function the integer form approximates), for every activation added here."""
    x = np.asarray(x, dtype=float)
    if name in SMOOTH:
        return slope(name, p) * np.maximum(x, 0.0) + smooth_g(name, p, x)
    if name == "hardsigmoid":
        return np.clip(p[0] * x + p[1], 0.0, 1.0)
    if name == "hardswish":
        return x * np.clip(HARDSWISH[0] * x + HARDSWISH[1], 0.0, 1.0)
    if name == "prelu":
        return np.where(x >= 0, x, np.asarray(p, dtype=float) * x)
    raise ValueError(name)


@dataclass(frozen=True)
class SmoothShape:
    """What the table and the bound need of one smooth activation (its parameters fixed)."""

    radius: float  # beyond +-radius, |g - its limit| <= tail
    tail: float  # sup over |x| >= radius of |g(x) - limit| (g is monotone there)
    lip_g: float  # sup |g'|
    lip_f: float  # sup |f'| (the Lipschitz constant the pre-activation error passes through)
    gmax: float  # sup |g|


@lru_cache(maxsize=64)
def shape_of(name: str, p: tuple[float, ...]) -> SmoothShape:
    """radius: the smallest whole R >= 2 with |g(+-R) - limit| <= 2^-(TABLE_STEP_FRAC + 2) (a quarter step,
    below the sampling error); g is monotone beyond 2 for every function here, so that is the tail's sup.
    sup |g'| and sup |f'|: the largest difference quotient on a 2^-GRID_FRAC grid over [-R - 1, R + 1] plus
    2^-GRID_FRAC x the curvature bound (the grid misses at most that); beyond, g' decays monotonically."""
    lo_lim, hi_lim = limits(name, p)
    want = 2.0 ** -(TABLE_STEP_FRAC + 2)
    r = 2.0
    while r < 64 and max(abs(_g_scalar(name, p, -r) - lo_lim), abs(_g_scalar(name, p, r) - hi_lim)) > want:
        r += 1.0
    tail = max(abs(_g_scalar(name, p, -r) - lo_lim), abs(_g_scalar(name, p, r) - hi_lim))
    h = 2.0**-GRID_FRAC
    x = np.arange(-(r + 1) / h, (r + 1) / h + 1) * h
    g = smooth_g(name, p, x)
    slack = h * _curvature(name, p)
    lip_g = float(np.max(np.abs(np.diff(g)))) / h + slack
    f = slope(name, p) * np.maximum(x, 0.0) + g
    lip_f = max(float(np.max(np.abs(np.diff(f)))) / h + slack, abs(slope(name, p)))
    gmax = max(float(np.max(np.abs(g))), abs(lo_lim), abs(hi_lim))
    return SmoothShape(r, tail, lip_g, lip_f, gmax)


def smooth_table(name: str, p: tuple[float, ...], in_frac: int, lo: int, hi: int, label: str) -> QTable:
    """Nearest-sample table of g in Q(in_frac) for inputs lo..hi (int16, Q(in_frac)), cut to +-radius:
    sample i is g((i - offset) step), step = 2^(in_shift - in_frac)."""
    sh = shape_of(name, p)
    in_shift = max(in_frac - TABLE_STEP_FRAC, 0)
    step = 2.0 ** (in_shift - in_frac)
    r = int(math.ceil(sh.radius / step))
    first = max(int(rshift_rne(int(lo), in_shift)), -r)
    last = min(int(rshift_rne(int(hi), in_shift)), r)
    first, last = min(first, last), max(first, last)
    x = np.arange(first, last + 1) * step
    values = np.clip(np.rint(smooth_g(name, p, x) * 2.0**in_frac), -(2**15), 2**15 - 1).astype(np.int64)
    return QTable(label, values, in_frac, in_frac, in_shift, -first)


def slope_q(name: str, p: tuple[float, ...]) -> int:
    """s in Q14 (s < 2: relu(y) s fits int32 for an int16 y)."""
    return int(round(slope(name, p) * 2**SLOPE_FRAC))


def smooth_error(name: str, p: tuple[float, ...], t: QTable, xmax: float) -> float:
    """Worst |integer - f(x)| (output units) for any input x on the Q(in_frac) grid with |x| <= xmax:
    nearest sample (sup |g'| x half a step; 0 when every input is a sample), the tail beyond the table's
    ends (cut at the radius), the table's rounding, s's Q14 rounding (|s - s_q| xmax + half an LSB; 0 for
    s = 1), Softplus's jump at its threshold, and the sat16 (never acts: the format holds s xmax + sup |g|,
    seagen/quant/activation.py)."""
    sh = shape_of(name, p)
    lsb = 2.0**-t.in_frac
    step = 2.0**t.in_shift * lsb
    sample = 0.0 if t.in_shift == 0 else sh.lip_g * step / 2
    s_q = slope_q(name, p)
    s_err = 0.0 if s_q == 2**SLOPE_FRAC else abs(slope(name, p) - s_q / 2**SLOPE_FRAC) * xmax + lsb / 2
    # torch's Softplus threshold: g jumps by log1p(e^-threshold) / beta at beta x = threshold, which a sample
    # on the other side of it may miss
    jump = math.log1p(math.exp(-p[1])) / p[0] if name == "softplus" and math.isfinite(p[1]) else 0.0
    return sample + sh.tail + lsb / 2 + s_err + jump


def smooth_s16(y: np.ndarray, t: QTable, slope_q14: int) -> np.ndarray:
    """sea_smooth_s16: sat16(rshift_rne(max(y, 0) s, 14) + g[clamp(rshift_rne(y, in_shift) + offset)])."""
    y = np.asarray(y, dtype=np.int64)
    k = np.clip(rshift_rne(y, t.in_shift) + t.offset, 0, len(t.values) - 1)
    return sat16(rshift_rne(np.maximum(y, 0) * slope_q14, SLOPE_FRAC) + t.values[k])


# ---- the piecewise-linear ones ---------------------------------------------------------------------------


def hsig_params(alpha: float, beta: float, in_frac: int) -> tuple[int, int]:
    """(alpha in Q(HSIG_FRAC - in_frac), beta in Q(HSIG_FRAC)): alpha x + beta in Q30 for x in Q(in_frac);
    alpha_q must fit int32 and beta_q int64 (the caller refuses otherwise)."""
    return int(round(alpha * 2.0 ** (HSIG_FRAC - in_frac))), int(round(beta * 2.0**HSIG_FRAC))


def hsig_s16(y: np.ndarray, a_q: int, b_q: int) -> np.ndarray:
    """sea_hsig1: clamp(rshift_rne(y a_q + b_q, 16), 0, 2^14), Q14 (int64 sum)."""
    v = np.asarray(y, dtype=np.int64) * np.int64(a_q) + np.int64(b_q)
    return np.clip(rshift_rne(v, HSIG_FRAC - TABLE_OUT_FRAC), 0, 2**TABLE_OUT_FRAC)


def hsig_error(alpha: float, beta: float, a_q: int, b_q: int, in_frac: int, xmax: float) -> float:
    """Worst |hsig_s16 - HardSigmoid| (output units) for |x| <= xmax: the constants' rounding and half a Q14
    LSB (clamping to [0, 1] is 1-Lipschitz: it adds nothing)."""
    da = abs(alpha - a_q * 2.0 ** (in_frac - HSIG_FRAC))
    db = abs(beta - b_q * 2.0**-HSIG_FRAC)
    return da * xmax + db + 2.0 ** -(TABLE_OUT_FRAC + 1)


def hswish_s16(y: np.ndarray, a_q: int, b_q: int) -> np.ndarray:
    """sea_hswish1: sat16(rshift_rne(y hsig_s16(y), 14)), in y's format (|y h| <= 2^29: int32)."""
    y = np.asarray(y, dtype=np.int64)
    return sat16(rshift_rne(y * hsig_s16(y, a_q, b_q), TABLE_OUT_FRAC))


def hswish_error(a_q: int, b_q: int, in_frac: int, xmax: float) -> float:
    """|x| x the HardSigmoid's error + half an output LSB."""
    return xmax * hsig_error(*HARDSWISH, a_q, b_q, in_frac, xmax) + 2.0 ** -(in_frac + 1)


def prelu_s16(y: np.ndarray, alpha_q15: np.ndarray) -> np.ndarray:
    """sea_prelu_s16 on a batch (N, n): y < 0 -> sat16(rshift_rne(y alpha_q15[j], 15)), per channel j."""
    y = np.asarray(y, dtype=np.int64)
    a = np.asarray(alpha_q15, dtype=np.int64)
    return np.where(y >= 0, y, sat16(rshift_rne(y * a, PRELU_FRAC)))


def interval(fn: Callable[[np.ndarray], np.ndarray], lo: np.ndarray, hi: np.ndarray) -> tuple:
    """Exact per-neuron [min, max] of an int16 activation over lo..hi: fn evaluated on every int16 once
    (fn gives (65536,) values, or (65536, n) for a per-channel one)."""
    out = fn(np.arange(-(2**15), 2**15, dtype=np.int64))
    out = out[:, None] if out.ndim == 1 else out
    spans = [
        (int(a) + 2**15, int(b) + 2**15 + 1, min(j, out.shape[1] - 1))
        for j, (a, b) in enumerate(zip(lo, hi, strict=True))
    ]
    mins = [int(out[a:b, j].min()) for a, b, j in spans]
    maxs = [int(out[a:b, j].max()) for a, b, j in spans]
    return np.array(mins, dtype=np.int64), np.array(maxs, dtype=np.int64)
