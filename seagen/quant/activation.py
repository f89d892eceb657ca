"""One layer's smooth or piecewise-linear activation quantized: its integer constants and table, the Q format
its output takes, the exact interval of its integer outputs and its worst error (the bound's hook)."""

from __future__ import annotations

import math

import numpy as np

from seagen.errors import UserError
from seagen.ir import FloatLayer, QLayer, QTable
from seagen.runtime import activations as A

ADDED = (*A.SMOOTH, "hardsigmoid", "hardswish", "prelu")  # the activations this module quantizes
INT32_MAX = 2**31 - 1


def params_of(layer: FloatLayer) -> tuple[float, ...]:
    """The float parameters act_float takes (HardSwish's are fixed)."""
    return A.HARDSWISH if layer.activation == "hardswish" else tuple(layer.params)


def format_magnitude(layer: FloatLayer, xmax: int, acc_frac: int) -> int:
    """The largest |value| (accumulator units) the layer's output format must hold: the pre-activation
    and, for a smooth function, s x + sup |g| (Softplus(0) = log 2 / beta whatever x)."""
    if layer.activation not in A.SMOOTH:
        return xmax
    p = params_of(layer)
    s = A.slope(layer.activation, p)
    g = A.shape_of(layer.activation, p).gmax
    return max(xmax, math.ceil(s * xmax + g * 2.0**acc_frac) + 1)


def quantize_act(
    layer: FloatLayer, pre_frac: int, lo: np.ndarray, hi: np.ndarray, index: int
) -> tuple[tuple[int, ...], QTable | None, int, np.ndarray, np.ndarray]:
    """(act_params, table, out_frac, y_lo, y_hi) for inputs lo..hi (int16, Q(pre_frac)), proven exactly."""
    act, p = layer.activation, params_of(layer)
    where = f"layer {index} ({act})"
    if act in A.SMOOTH:
        s = A.slope(act, p)
        if not 0 < s < 2:
            raise UserError(f"{where}: scale {s:g} (seagen reads scales in (0, 2))")
        t = A.smooth_table(act, p, pre_frac, int(np.min(lo)), int(np.max(hi)), f"l{index}_{act}")
        s_q = A.slope_q(act, p)
        y_lo, y_hi = A.interval(lambda y: A.smooth_s16(y, t, s_q), lo, hi)
        return (s_q,), t, pre_frac, y_lo, y_hi
    if act in ("hardsigmoid", "hardswish"):
        a_q, b_q = A.hsig_params(p[0], p[1], pre_frac)
        if not (abs(a_q) <= INT32_MAX and abs(b_q) < 2**40):
            raise UserError(
                f"{where}: alpha {p[0]:g} / beta {p[1]:g} do not fit the integer form at Q{pre_frac}"
            )
        if act == "hardsigmoid":
            y_lo, y_hi = A.interval(lambda y: A.hsig_s16(y, a_q, b_q), lo, hi)
            return (a_q, b_q), None, A.TABLE_OUT_FRAC, y_lo, y_hi
        y_lo, y_hi = A.interval(lambda y: A.hswish_s16(y, a_q, b_q), lo, hi)
        return (a_q, b_q), None, pre_frac, y_lo, y_hi
    slopes = np.broadcast_to(np.asarray(p, dtype=float), (len(lo),))
    if not np.all(np.abs(slopes) <= 1.0):
        raise UserError(
            f"{where}: PReLU slopes up to {np.max(np.abs(slopes)):g} (seagen reads -1..1 exactly)"
        )
    a = tuple(int(v) for v in np.rint(slopes * 2**A.PRELU_FRAC))
    y_lo, y_hi = A.interval(lambda y: A.prelu_s16(y[:, None], np.array(a)[None, :]), lo, hi)
    return a, None, pre_frac, y_lo, y_hi


def apply(q: QLayer, table: QTable | None, y: np.ndarray) -> np.ndarray:
    """The integer activation on a batch (N, n) of int16 values (the numpy reference's)."""
    if q.activation in A.SMOOTH:
        assert table is not None
        return A.smooth_s16(y, table, q.act_params[0])
    if q.activation == "hardsigmoid":
        return A.hsig_s16(y, *q.act_params)
    if q.activation == "hardswish":
        return A.hswish_s16(y, *q.act_params)
    return A.prelu_s16(y, np.array(q.act_params, dtype=np.int64)[None, :])


def lipschitz(layer: FloatLayer, shape: tuple[int, ...]) -> float | np.ndarray:
    """sup |f'| of the layer's added activation (per neuron for PReLU, broadcast to `shape`): the factor a
    pre-activation error passes through (the integer bound's and the float margin's)."""
    act, p = layer.activation, params_of(layer)
    if act in A.SMOOTH:
        return A.shape_of(act, p).lip_f
    if act == "hardsigmoid":
        return abs(p[0])
    if act == "hardswish":  # |d/dx x h(x)| <= 2 alpha 3 + beta = 1.5 on [-3, 3], 1 beyond
        return 1.5
    return np.maximum(1.0, np.abs(np.broadcast_to(np.asarray(p, dtype=float), shape)))


def act_error(
    layer: FloatLayer, q: QLayer, table: QTable | None, ez: np.ndarray, zmax: np.ndarray
) -> np.ndarray:
    """The bound's hook: per neuron, the output error given the pre-activation's error ez and |z| <= zmax:
    Lipschitz(f) ez + the integer form's worst error for inputs |x| <= xmax (zmax + ez, and never more than
    int16 holds at Q(pre_frac))."""
    act, p = layer.activation, params_of(layer)
    f = q.pre_frac
    xmax = float(min(np.max(zmax + ez) + 2.0**-f, 2.0 ** (15 - f)))
    lip = lipschitz(layer, ez.shape)
    if act in A.SMOOTH:
        assert table is not None
        return lip * ez + A.smooth_error(act, p, table, xmax)
    if act == "hardsigmoid":
        return lip * ez + A.hsig_error(p[0], p[1], q.act_params[0], q.act_params[1], f, xmax)
    if act == "hardswish":
        return lip * ez + A.hswish_error(q.act_params[0], q.act_params[1], f, xmax)
    slopes = np.broadcast_to(np.asarray(p, dtype=float), ez.shape)
    a_q = np.array(q.act_params, dtype=float) / 2**A.PRELU_FRAC
    return lip * ez + np.abs(slopes - a_q) * zmax + 2.0 ** -(f + 1)
