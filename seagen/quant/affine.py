"""A tighter proven MLP error bound: symbolic intervals per neuron, affine in the inputs, on sub-boxes."""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from seagen.ir import QMLP, FloatLayer, FloatMLP, QLayer
from seagen.quant.qformat import widened
from seagen.runtime.activations import table_error

AFFINE = ("linear", "relu", "leaky_relu", "hardtanh", "tanh", "sigmoid")  # activations this module bounds
WORK = 4e6  # multiply-adds spent on the sub-boxes at quantization (the splits per input follow from it)
# tighten() refines up to this much: ~10 s of one core on a 4-64-64-64-1 network, the only size that needs
# it so far (a freshly initialised int8 one reaches 6.9x its measured error there, 38x at 1e9)
WORK_MAX = 1.6e10
MAX_BOXES = 8192  # tighten()'s sub-box evaluations at most (a small network's cheap boxes stop here)
STALL = 0.9  # tighten() stops when a refinement gains less than 10 %
MAX_SPLIT = 12  # sub-boxes per input at most
CHUNK = 256  # sub-boxes evaluated together
BAB_SHARE = 1.0  # the first, even grid gets 1/BAB_SHARE of the work; the rest splits the worst sub-boxes
BAB_KEEP = 0.7  # sub-boxes whose bound is within this factor of the largest are split


@dataclass(frozen=True)
class Form:
    """A vector of quantities on a batch of sub-boxes: c + A eta + [-r, r], eta in [-1, 1]^d the sub-box's
    own coordinates (A shares them between neurons, so correlations survive), r >= 0 what is not (yet)
    affine (roundings, relaxed activations), per neuron. Neuron-major, so a dense layer is one product."""

    c: np.ndarray  # (n, B)
    a: np.ndarray  # (n, B, symbols)
    r: np.ndarray  # (n, B)

    @cached_property
    def spread(self) -> np.ndarray:
        """Largest |q - c| over the sub-box."""
        return np.abs(self.a).sum(axis=2) + self.r

    def widen(self, r: np.ndarray | float) -> Form:
        """The form with its radius grown by r."""
        return Form(self.c, self.a, self.r + r)

    def lo(self) -> np.ndarray:
        return self.c - self.spread

    def hi(self) -> np.ndarray:
        return self.c + self.spread

    def mag(self) -> np.ndarray:
        """Largest |q| over the sub-box."""
        return np.abs(self.c) + self.spread

    def plus(self, o: Form) -> Form:
        a, b = _aligned(self.a, o.a)
        return Form(self.c + o.c, a + b, self.r + o.r)

    def where(self, m: np.ndarray, o: Form) -> Form:
        """Per neuron: self where m, else o."""
        a, b = _aligned(self.a, o.a)
        return Form(np.where(m, self.c, o.c), np.where(m[..., None], a, b), np.where(m, self.r, o.r))


def _aligned(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two coefficient arrays over the same symbols (the shorter one's missing symbols at 0: a value form
    has the inputs' symbols only, an error form also the noise symbols added after them)."""
    w = max(a.shape[2], b.shape[2])
    return _pad(a, w), _pad(b, w)


def _pad(a: np.ndarray, w: int) -> np.ndarray:
    if a.shape[2] == w:
        return a
    return np.concatenate([a, np.zeros((*a.shape[:2], w - a.shape[2]))], axis=2)


def _dense(w: np.ndarray, x: Form, b: np.ndarray | float = 0.0) -> Form:
    """W x + b on a form (W is exact: its products are sums of the form's terms, r through |W|)."""
    n, bn, k = x.a.shape
    a = (w @ x.a.reshape(n, bn * k)).reshape(len(w), bn, k)
    return Form(w @ x.c + np.reshape(b, (-1, 1)), a, np.abs(w) @ x.r)


def _scale(s: np.ndarray | float, x: Form) -> Form:
    s = np.asarray(s, dtype=float)
    return Form(s * x.c, s[..., None] * x.a if s.ndim else s * x.a, np.abs(s) * x.r)


def _const(c: np.ndarray, r: np.ndarray, d: int) -> Form:
    """A form with no affine part: [c - r, c + r]."""
    return Form(c, np.zeros((*c.shape, d)), r)


def _interval(lo: np.ndarray, hi: np.ndarray, d: int) -> Form:
    return _const((lo + hi) / 2, (hi - lo) / 2, d)


def _boxes(work: float, per_box: float) -> float:
    """How many sub-boxes `work` buys: work / per_box, beyond quantization's WORK at most MAX_BOXES (or what
    WORK buys, if more)."""
    per_box = max(per_box, 1.0)
    return min(work, max(WORK, per_box * MAX_BOXES)) / per_box


def sub_boxes(
    lo: np.ndarray, hi: np.ndarray, per_box: float, work: float = WORK
) -> tuple[np.ndarray, np.ndarray]:
    """Centres and half-widths (B, d) of a grid of sub-boxes of lo..hi, as many as work / per_box allows."""
    d = len(lo)
    k = max(1, min(MAX_SPLIT, int(_boxes(work, per_box) ** (1.0 / d) + 1e-9)))
    edges = [np.linspace(a, b, k + 1) for a, b in zip(lo, hi, strict=True)]
    cells = np.array(list(itertools.product(range(k), repeat=d)), dtype=int)
    left = np.stack([edges[j][cells[:, j]] for j in range(d)], axis=1)
    right = np.stack([edges[j][cells[:, j] + 1] for j in range(d)], axis=1)
    return (left + right) / 2, (right - left) / 2


def tighten(model: FloatMLP, qm: QMLP, goal: float) -> QMLP:
    """qm with its proven bound refined on ever finer sub-boxes (x8 the work each time, up to WORK_MAX)
    until it is at most `goal` (e.g. a multiple of the error measured at export), or as tight as that
    work makes it (stopping early when a refinement gains less than 1 - STALL)."""
    work, bound = WORK, qm.error_bound
    while bound > goal and work < WORK_MAX:
        work = min(work * 8, WORK_MAX)
        finer = affine_error_bound(model, qm, work)
        stalled = finer > STALL * bound
        bound = min(bound, finer)
        if stalled:
            break
    return dataclasses.replace(qm, error_bound=bound)


def affine_error_bound(model: FloatMLP, qm: QMLP, work: float = WORK) -> float:
    """Bound on |infer(quantize(x)) * 2^-out_frac - float(x)| over the widened box (output units), or inf for
    an activation this module does not bound (the caller keeps the layer-by-layer bound then).

    Per sub-box, two forms are carried through the layers: the float network's value v and the error
    e = fixed - float. A dense layer: z = W v + b and e_z = (W^ - W) v + W^ e + (b^ - b) + rho, |rho| <= half
    an LSB of the rounding shift (0 for no shift), the input's own rounding half an input LSB. Activations:
    where a neuron's float and fixed pre-activations are on one linear piece over the sub-box the error goes
    through symbolically; elsewhere it is bounded by its interval (ReLU, clamps: between 0 and e_z; leaky:
    both slopes). The float value through ReLU/leaky/clamp/tanh/sigmoid is relaxed by the chord with its
    exact largest deviation; through tanh/sigmoid the error is f'(mid) e_z plus the spread of f' over the
    sub-box's range times |e_z| plus the table's own error.
    """
    if any(fl.activation not in AFFINE for fl in model.layers):
        return math.inf
    boxes = np.array([widened(s.lo, s.hi) for s in model.inputs])
    d = len(boxes)
    per_box = _cost(model, d)
    budget = int(_boxes(work, per_box))  # sub-box evaluations
    centre, half = sub_boxes(boxes[:, 0], boxes[:, 1], per_box * BAB_SHARE, work)
    bound = _chunked(model, qm, centre, half)
    used = len(centre)
    full = (boxes[:, 1] - boxes[:, 0]) / 2
    while used < budget:
        worst = float(np.max(bound))
        pick = bound >= BAB_KEEP * worst  # split the sub-boxes that set the bound, along their widest side
        take = np.flatnonzero(pick)[: max(1, (budget - used) // 2)]
        if len(take) == 0:
            break
        c, h = centre[take], half[take]
        j = np.argmax(h / full, axis=1)
        step = np.zeros_like(h)
        step[np.arange(len(take)), j] = h[np.arange(len(take)), j] / 2
        kids_c, kids_h = np.vstack([c - step, c + step]), np.vstack([h - step, h - step])
        kid_b = _chunked(model, qm, kids_c, kids_h)
        keep = np.ones(len(centre), dtype=bool)
        keep[take] = False
        centre, half = np.vstack([centre[keep], kids_c]), np.vstack([half[keep], kids_h])
        bound = np.concatenate([bound[keep], kid_b])
        used += len(kids_c)
    return float(np.max(bound))


def _cost(model: FloatMLP, d: int) -> float:
    """Multiply-adds of one sub-box: three products per layer over the symbols so far."""
    width, total = d, 0.0
    for fl in model.layers:
        total += 3.0 * fl.weight.size * width
        width += 2 * fl.weight.shape[0]
    return total


def _chunked(model: FloatMLP, qm: QMLP, centre: np.ndarray, half: np.ndarray) -> np.ndarray:
    """box_bounds in chunks of CHUNK sub-boxes (bounded memory)."""
    parts = [
        box_bounds(model, qm, centre[i : i + CHUNK], half[i : i + CHUNK])
        for i in range(0, len(centre), CHUNK)
    ]
    return np.concatenate(parts)


def box_bounds(model: FloatMLP, qm: QMLP, centre: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Per sub-box (centre, half-widths (B, d)): the bound on |fixed - float| over it."""
    nb, d = centre.shape
    v = Form(centre.T, np.eye(d)[:, None, :] * half.T[:, :, None], np.zeros((d, nb)))
    e_in = np.array([2.0 ** -(i.frac + 1) for i in qm.inputs])
    e = _const(np.zeros((d, nb)), np.repeat(e_in[:, None], nb, axis=1), d)
    scale = np.array([2.0**i.frac for i in qm.inputs])
    tables = {t.name: t for t in qm.tables}
    for k, (fl, q) in enumerate(zip(model.layers, qm.layers, strict=True)):
        w_hat = q.w_q * 2.0**-q.w_frac * (scale[None, :] if k == 0 else 1.0)
        b_hat = q.b_q * 2.0 ** -(q.w_frac + q.in_frac)
        rho = 2.0 ** -(q.pre_frac + 1) if q.shift > 0 else 0.0
        z = _dense(fl.weight, v, fl.bias)
        ez = _dense(w_hat - fl.weight, v, b_hat - fl.bias).plus(_dense(w_hat, e))
        ez = ez.widen(rho)
        v, e = _activation(fl, q, z, ez, tables.get(f"l{k}_{fl.activation}"), d)
        if k + 1 < len(model.layers):
            v, e = _symbols(v, e)
    return np.max(e.mag(), axis=0)


def _symbols(v: Form, e: Form) -> tuple[Form, Form]:
    """Each neuron's non-affine radius (of the value and of the error) made a symbol of its own (affine
    arithmetic's noise symbols, shared by both forms): the next layers keep its sign, so the same rounding or
    relaxation reaching the output by several paths cancels where the weights' signs cancel it instead of
    adding up through |W|."""
    va, ea = _aligned(v.a, e.a)
    n, b = v.r.shape
    eye = np.eye(n)[:, None, :]
    zero = np.zeros((n, b, n))
    va = np.concatenate([va, v.r[:, :, None] * eye, zero], axis=2)
    ea = np.concatenate([ea, zero, e.r[:, :, None] * eye], axis=2)
    return Form(v.c, va, np.zeros_like(v.r)), Form(e.c, ea, np.zeros_like(e.r))


def _activation(fl: FloatLayer, q: QLayer, z: Form, ez: Form, table, d: int) -> tuple[Form, Form]:
    """(float value, error) after the layer's activation."""
    act = fl.activation
    if act == "linear":
        return z, ez
    zh = z.plus(ez)  # the fixed-point pre-activation (rounded: its rounding is in ez)
    lo, hi, lo_h, hi_h = z.lo(), z.hi(), zh.lo(), zh.hi()
    elo, ehi = ez.lo(), ez.hi()
    between = _between(ez, elo, ehi)  # a monotone 1-Lipschitz step of the error: t e_z, 0 <= t <= 1
    if act == "relu":
        on = (lo >= 0) & (lo_h >= 0)
        off = (hi <= 0) & (hi_h <= 0)
        zero = _const(np.zeros_like(lo), np.zeros_like(lo), d)
        return _relaxed(z, lo, hi, 0.0, 1.0), ez.where(on, zero.where(off, between))
    if act == "leaky_relu":
        return _leaky(fl, q, z, ez, lo, hi, lo_h, hi_h, d)
    if act == "hardtanh":
        return _clamp(fl, q, z, ez, lo, hi, lo_h, hi_h, between, d)
    return _smooth(act, z, ez, lo, hi, lo_h, hi_h, table_error(table, act), d)


def _between(ez: Form, elo: np.ndarray, ehi: np.ndarray) -> Form:
    """t e_z for some 0 <= t <= 1 (per point): e_z / 2 +- |e_z| / 2 (half the form kept), or the interval
    [min(0, e_z), max(0, e_z)] where that is narrower."""
    big = np.maximum(np.abs(elo), np.abs(ehi))
    half = _scale(0.5, ez)
    half = half.widen(big / 2)
    box = _interval(np.minimum(elo, 0.0), np.maximum(ehi, 0.0), ez.a.shape[2])
    return half.where(half.mag() <= box.mag(), box)


def _relaxed(z: Form, lo: np.ndarray, hi: np.ndarray, a_neg: float, a_pos: float) -> Form:
    """a_neg z (z < 0) / a_pos z (z >= 0) on a form: exact where one piece holds, else the chord through
    the range's ends plus [min, max] of the deviation (0 at the ends, -chord(0) at the kink)."""
    cross = (lo < 0) & (hi > 0)
    w = np.where(cross, hi - lo, 1.0)
    lam = np.where(cross, (a_pos * hi - a_neg * lo) / w, np.where(hi <= 0, a_neg, a_pos))
    c0 = np.where(cross, a_pos * hi - lam * hi, 0.0)  # the chord at 0; the function is 0 there
    dev_lo, dev_hi = np.minimum(0.0, -c0), np.maximum(0.0, -c0)
    out = _scale(lam, z)
    return Form(out.c + c0 + (dev_lo + dev_hi) / 2, out.a, out.r + (dev_hi - dev_lo) / 2)


def _leaky(fl, q, z, ez, lo, hi, lo_h, hi_h, d):
    """LeakyReLU: fixed alpha^ = alpha_q15 / 2^15, its product rounded again (half an LSB)."""
    a, a_hat = fl.alpha, q.act_params[0] / 2**15
    rho = 2.0 ** -(q.pre_frac + 1)
    pos = (lo >= 0) & (lo_h >= 0)
    neg = (hi < 0) & (hi_h < 0)
    e_neg = _scale(a_hat, ez).plus(_scale(a_hat - a, z))
    e_neg = e_neg.widen(rho)
    worst = max(1.0, abs(a_hat)) * np.maximum(np.abs(ez.lo()), np.abs(ez.hi())) + abs(a_hat - a) * z.mag()
    mixed = _const(np.zeros_like(lo), worst + rho, d)
    return _relaxed(z, lo, hi, a, 1.0), ez.where(pos, e_neg.where(neg, mixed))


def _clamp(fl, q, z, ez, lo, hi, lo_h, hi_h, between, d):
    """Hardtanh: float limits fl.lo..fl.hi, fixed ones act_params (Q pre_frac; +-inf sides never clamp)."""
    s = 2.0**-q.pre_frac
    t_lo, t_hi = q.act_params[0] * s, q.act_params[1] * s
    inside = (lo >= max(fl.lo, t_lo)) & (hi <= min(fl.hi, t_hi)) & (lo_h >= t_lo) & (hi_h <= t_hi)
    moved = max(
        _moved(fl.lo, t_lo, q.act_params[0] == -(2**15)), _moved(fl.hi, t_hi, q.act_params[1] == 2**15 - 1)
    )
    out = _interval(np.clip(lo, fl.lo, fl.hi), np.clip(hi, fl.lo, fl.hi), d)
    val = z.where(inside, out)
    far = Form(between.c, between.a, between.r + moved)
    # pinned to one limit in both (min > max: every output is the upper one, in ONNX, torch and numpy)
    top = (lo >= fl.hi) & (lo_h >= t_hi) | (fl.lo >= fl.hi and t_lo >= t_hi)
    bottom = (hi <= fl.lo) & (hi_h <= t_lo) & ~top
    with np.errstate(invalid="ignore"):
        gap = np.where(top, t_hi - fl.hi, np.where(bottom, t_lo - fl.lo, 0.0))
    pinned = _const(gap, np.zeros_like(gap), d)
    return val, pinned.where(top | bottom, ez.where(inside, far))


def _moved(limit: float, fixed: float, at_int16_end: bool) -> float:
    """How far the fixed clamp limit is from the float one (an infinite limit: never reached by an int16
    value when the fixed one is the int16 end)."""
    if math.isfinite(limit):
        return abs(limit - fixed)
    return 0.0 if at_int16_end else math.inf


def _smooth(act, z, ez, lo, hi, lo_h, hi_h, t_err, d):
    """tanh / sigmoid: chord relaxation of the float value; the error through f' on the joint range."""
    f = np.tanh if act == "tanh" else (lambda x: 1.0 / (1.0 + np.exp(-x)))
    df = (lambda x: 1.0 - np.tanh(x) ** 2) if act == "tanh" else (lambda x: f(x) * (1.0 - f(x)))
    w = np.maximum(hi - lo, 1e-300)
    flat = (hi - lo) < 1e-12
    lam = np.where(flat, df((lo + hi) / 2), (f(hi) - f(lo)) / w)
    dev = [f(lo) - lam * lo, f(hi) - lam * hi]
    for t in _tangent_points(act, lam):  # where f' = lam (the deviation's stationary points)
        inside = (t > lo) & (t < hi)
        dev.append(np.where(inside, f(t) - lam * t, dev[0]))
    dmin, dmax = np.minimum.reduce(dev), np.maximum.reduce(dev)
    val = _scale(lam, z)
    val = Form(val.c + (dmin + dmax) / 2, val.a, val.r + (dmax - dmin) / 2)
    jl, jh = np.minimum(lo, lo_h), np.maximum(hi, hi_h)
    near = np.where((jl <= 0) & (jh >= 0), 0.0, np.minimum(np.abs(jl), np.abs(jh)))
    far = np.maximum(np.abs(jl), np.abs(jh))
    g_hi, g_lo = df(near), df(far)  # f' is even and falls with |x|
    mid = (g_hi + g_lo) / 2
    err = _scale(mid, ez)
    err = err.widen((g_hi - g_lo) / 2 * np.maximum(np.abs(ez.lo()), np.abs(ez.hi())) + t_err)
    return val, err


def _tangent_points(act: str, lam: np.ndarray) -> list[np.ndarray]:
    """The x with f'(x) = lam (tanh: 1 - t^2 = lam; sigmoid: s (1 - s) = lam), both signs."""
    with np.errstate(invalid="ignore", divide="ignore"):
        if act == "tanh":
            t = np.sqrt(np.clip(1.0 - lam, 0.0, 1.0 - 1e-16))
            x = np.arctanh(t)
        else:
            s = (1.0 + np.sqrt(np.clip(1.0 - 4.0 * lam, 0.0, 1.0 - 1e-16))) / 2.0
            x = np.log(s / (1.0 - s))
    x = np.nan_to_num(x, nan=0.0)
    return [x, -x]
