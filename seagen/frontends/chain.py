"""The op chain every frontend reads a model into, and the named passes that normalise it to float layers.

A chain is what the model computes from its one input to its one output, in order: dense layers, elementwise
activations, constant elementwise affine maps (Add/Sub/Mul/Div by a constant, BatchNorm in eval mode) and
no-ops (Dropout, Identity, casts to float, reshapes to the same shape); clips in a row are the one clip they
compose to. Each item remembers the op and the node or module path it came from, so a refusal can name it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from seagen.errors import UserError
from seagen.ir import FloatLayer

SUPPORTED = (
    "supported: a chain of distinct dense layers (Linear, Gemm, MatMul+Add), each followed by at most one "
    "of ReLU, LeakyReLU, PReLU, Hardtanh, ReLU6, Clip (ONNX: or Max/Min by a number), Tanh, Sigmoid, ELU, "
    "SELU, Softplus, GELU (erf or tanh; ONNX: or its erf pattern), Mish, SiLU (or x*sigmoid(x)), "
    "HardSigmoid, HardSwish; constant "
    "Add/Sub/Mul/Div, BatchNorm (eval), Dropout, Identity, Flatten, casts to float; at the input and output, "
    "Unsqueeze/Squeeze/Reshape/Flatten that keep whole rows"
)


@dataclass(frozen=True, eq=False)
class Item:
    """Where an item came from: the op as the producer named it and the node or module path."""

    op: str
    path: str


@dataclass(frozen=True, eq=False)
class Dense(Item):
    """y = W x + b; W has shape (out, in)."""

    weight: np.ndarray
    bias: np.ndarray


@dataclass(frozen=True, eq=False)
class Act(Item):
    """An elementwise activation of the IR: relu, leaky_relu (alpha), hardtanh (lo, hi), tanh, sigmoid, and
    those with params (FloatLayer.params: elu, selu, softplus, hardsigmoid, prelu slopes; gelu, gelu_tanh,
    mish, silu, hardswish take none)."""

    kind: str
    alpha: float = 0.01
    lo: float = -1.0
    hi: float = 1.0
    params: tuple[float, ...] = ()


@dataclass(frozen=True, eq=False)
class Affine(Item):
    """y = x * scale + shift elementwise (scale and shift broadcast to the width)."""

    scale: np.ndarray
    shift: np.ndarray


@dataclass(frozen=True, eq=False)
class Reshape(Item):
    """A reshape to (batch, width): a no-op when width is the current width."""

    width: int


def refuse(where: str, item: Item, why: str) -> UserError:
    """The one-line refusal: file, node or module path, op, why, and what is supported."""
    return UserError(f"{where}: {item.path or '?'} ({item.op}): {why}; {SUPPORTED}")


def _number(v: object) -> float:
    """A bound given as a number or a one-element array."""
    return float(np.asarray(v, dtype=float).reshape(-1)[0])


def clip_act(op: str, path: str, lo: float | None, hi: float | None) -> Act:
    """Clip/clamp/Hardtanh/ReLU6 with one or two bounds (None = unbounded) as an IR activation; min > max
    gives max everywhere (as ONNX Clip and torch.clamp define it)."""
    lo_f = -np.inf if lo is None else _number(lo)
    hi_f = np.inf if hi is None else _number(hi)
    lo_f = min(lo_f, hi_f)
    if lo_f == 0.0 and hi_f == np.inf:
        return Act(op, path, "relu")
    return Act(op, path, "hardtanh", lo=lo_f, hi=hi_f)


def _clip_bounds(it: Item) -> tuple[float, float] | None:
    """The [lo, hi] of a clip activation (ReLU, Hardtanh and its forms), None for any other item."""
    if isinstance(it, Act) and it.kind == "relu":
        return 0.0, np.inf
    if isinstance(it, Act) and it.kind == "hardtanh":
        return it.lo, it.hi
    return None


def merge_clips(items: list[Item]) -> list[Item]:
    """Clips in a row as the one clip they are: clip(clip(x, a, b), c, d) = clip(x, L, H) with L, H the
    clip of a, b to [c, d] (ReLU then Min(x, 6) is ReLU6; Max(x, 0) then Min(x, 6) too)."""
    out: list[Item] = []
    for it in items:
        second = _clip_bounds(it)
        first = _clip_bounds(out[-1]) if out else None
        if first is None or second is None:
            out.append(it)
            continue
        (a, b), (c, d) = first, second
        prev = out.pop()
        out.append(clip_act(f"{prev.op}+{it.op}", prev.path, min(max(a, c), d), min(max(b, c), d)))
    return out


def batchnorm_affine(op: str, path: str, gamma, beta, mean, var, eps: float) -> Affine:
    """An eval-mode batch normalisation as the elementwise affine map it is: x * s + (beta - mean * s),
    s = gamma / sqrt(var + eps)."""
    s = np.asarray(gamma, dtype=float) / np.sqrt(np.asarray(var, dtype=float) + float(eps))
    return Affine(op, path, s, np.asarray(beta, dtype=float) - np.asarray(mean, dtype=float) * s)


def _vec(a: np.ndarray, n: int, where: str, item: Item) -> np.ndarray:
    """A constant broadcast to a width-n vector (scalar, (n,), (1, n)); anything else is refused."""
    a = np.asarray(a, dtype=float)
    if a.size == 1:
        return np.full(n, float(a.reshape(-1)[0]))
    if a.size == n and (a.ndim == 1 or (a.ndim == 2 and a.shape[0] == 1)):
        return a.reshape(-1)
    raise refuse(where, item, f"constant of shape {a.shape} does not broadcast over {n} features")


def fold_affines(items: list[Item], n_in: int, where: str) -> list[Item]:
    """Fold every Affine into the Dense it touches with no activation between, else into the next Dense,
    else (after the last activation) into an added square output layer."""
    out: list[Item] = []
    pending: Affine | None = None  # an affine waiting for the next Dense
    width = n_in
    for it in items:
        if isinstance(it, Dense):
            w, b = it.weight, it.bias
            if pending is not None:
                s, t = _vec(pending.scale, width, where, pending), _vec(pending.shift, width, where, pending)
                w, b = w * s[None, :], b + w @ t
                pending = None
            width = w.shape[0]
            out.append(Dense(it.op, it.path, w, b))
        elif isinstance(it, Affine):
            s, t = _vec(it.scale, width, where, it), _vec(it.shift, width, where, it)
            if out and isinstance(out[-1], Dense) and pending is None:
                d = out[-1]
                out[-1] = Dense(d.op, d.path, d.weight * s[:, None], d.bias * s + t)
            elif pending is not None:
                ps, pt = pending.scale, pending.shift
                pending = Affine(pending.op, pending.path, ps * s, pt * s + t)
            else:
                pending = Affine(it.op, it.path, s, t)
        else:
            if pending is not None:
                out.append(Dense(pending.op, pending.path, np.diag(pending.scale), pending.shift.copy()))
                pending = None
            out.append(it)
    if pending is not None:
        out.append(Dense(pending.op, pending.path, np.diag(pending.scale), pending.shift.copy()))
    return out


def drop_reshapes(items: list[Item], n_in: int, where: str) -> list[Item]:
    """Remove reshapes to the current (batch, width); any other reshape is refused."""
    out, width = [], n_in
    for it in items:
        if isinstance(it, Dense):
            width = it.weight.shape[0]
        if isinstance(it, Reshape):
            if it.width not in (-1, width):
                raise refuse(where, it, f"reshape to width {it.width} of {width} features")
            continue
        out.append(it)
    return out


def to_layers(items: list[Item], n_in: int, where: str) -> list[FloatLayer]:
    """Normalised chain -> float layers: each Dense followed by at most one activation."""
    layers: list[FloatLayer] = []
    width = n_in
    for it in fold_affines(merge_clips(drop_reshapes(items, n_in, where)), n_in, where):
        if isinstance(it, Dense):
            if not layers and it.weight.ndim == 2 and it.weight.shape[1] != width:
                raise UserError(
                    f"{where}: {it.path} ({it.op}) takes {it.weight.shape[1]} inputs but the model input has "
                    f"{width} (the feature specification or the graph input)"
                )
            if it.weight.ndim != 2 or it.weight.shape[1] != width or it.bias.shape != (it.weight.shape[0],):
                raise refuse(
                    where, it, f"weight {it.weight.shape} / bias {it.bias.shape} do not fit width {width}"
                )
            if not (np.all(np.isfinite(it.weight)) and np.all(np.isfinite(it.bias))):
                raise refuse(where, it, "weights contain NaN or Inf")
            layers.append(FloatLayer(np.asarray(it.weight, float), np.asarray(it.bias, float)))
            width = it.weight.shape[0]
        elif isinstance(it, Act):
            if not layers:
                raise refuse(where, it, "an activation before any dense layer")
            last = layers[-1]
            if last.activation != "linear":
                raise refuse(where, it, f"a second activation right after {last.activation} (stacked)")
            if it.kind == "hardtanh" and not it.lo <= it.hi:
                raise refuse(where, it, f"clip bounds [{it.lo}, {it.hi}] are not numbers")
            if it.kind == "leaky_relu" and not -1.0 <= it.alpha <= 1.0:
                raise refuse(
                    where, it, f"LeakyReLU slope {it.alpha} (seagen reads slopes between -1 and 1 exactly)"
                )
            params = _act_params(it, last.weight.shape[0], where)
            layers[-1] = FloatLayer(last.weight, last.bias, it.kind, it.alpha, it.lo, it.hi, params)
        else:
            raise refuse(where, it, "not a supported op")
    if not layers:
        raise UserError(f"{where}: no dense layer found; {SUPPORTED}")
    return layers


def _act_params(it: Act, width: int, where: str) -> tuple[float, ...]:
    """The activation's float parameters, checked (finite; Softplus beta > 0; PReLU slopes, broadcast over
    the layer's width, in -1..1 as LeakyReLU's)."""
    p = np.asarray(it.params, dtype=float).reshape(-1)
    finite = p if it.kind != "softplus" else p[:1]  # Softplus's threshold may be infinite (none)
    if not np.all(np.isfinite(finite)) or np.any(np.isnan(p)):
        raise refuse(where, it, f"parameters {tuple(p.tolist())} are not finite numbers")
    if it.kind == "softplus" and not p[0] > 0:
        raise refuse(where, it, f"Softplus beta {p[0]} (seagen reads beta > 0)")
    if it.kind == "prelu":
        if p.size not in (1, width):
            raise refuse(where, it, f"{p.size} PReLU slopes for {width} channels")
        p = np.broadcast_to(p, (width,))
        if not np.all(np.abs(p) <= 1.0):
            raise refuse(where, it, f"PReLU slopes up to {np.max(np.abs(p))} (seagen reads slopes in -1..1)")
    return tuple(float(v) for v in p)
