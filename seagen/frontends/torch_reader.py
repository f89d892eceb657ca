"""torch.export graph (ATen ops) -> op chain: what the module computes, not how its layers were registered."""

from __future__ import annotations

from typing import Any

import numpy as np

from seagen.errors import UserError
from seagen.frontends.chain import Act, Affine, Dense, Item, Reshape, batchnorm_affine, clip_act, refuse
from seagen.frontends.graph import Node, chain_nodes
from seagen.frontends.joined import joined_inputs
from seagen.runtime.activations import SELU

_ACTS = {"aten.relu.default": "relu", "aten.tanh.default": "tanh", "aten.sigmoid.default": "sigmoid"}
_NOOPS = (
    "aten.clone.default",
    "aten.alias.default",
    "aten.contiguous.default",
    "aten.detach.default",
    "aten.flatten.using_ints",
    "<built-in function getitem>",
)
_FLOATS = ("torch.float32", "torch.float64")
_DENSE = ("aten.linear.default", "aten.addmm.default", "aten.mm.default", "aten.matmul.default")
_SMOOTH = {
    "aten.elu.default": "elu",
    "aten.selu.default": "selu",
    "aten.softplus.default": "softplus",
    "aten.gelu.default": "gelu",
    "aten.mish.default": "mish",
    "aten.silu.default": "silu",
    "aten.hardsigmoid.default": "hardsigmoid",
    "aten.hardswish.default": "hardswish",
    "aten.prelu.default": "prelu",
    "aten._prelu_kernel.default": "prelu",
}
_CLAMPS = ("aten.hardtanh.default", "aten.clamp.default", "aten.clamp_min.default", "aten.clamp_max.default")
_BATCHNORM = ("aten.batch_norm.default", "aten._native_batch_norm_legit_no_training.default")
_CASTS = ("aten.to.dtype", "aten._to_copy.default", "aten.to.dtype_layout")
_VIEWS = ("aten.view.default", "aten.reshape.default", "aten._unsafe_view.default")
# Every ATen op a graph may hold, dead nodes included, before anything of it is evaluated (constant folding
# runs ops): what the reader turns into the chain, and pure tensor arithmetic that prepares constants (a
# transposed or reshaped weight, ones, a folded scale). Anything else (file I/O such as aten.from_file,
# printing, random ops) is refused by name. Python arithmetic on symbolic sizes is pure too.
_READ_OPS = {
    *_ACTS,
    *_NOOPS,
    *_DENSE,
    *_CLAMPS,
    *_BATCHNORM,
    *_CASTS,
    *_VIEWS,
    "aten.leaky_relu.default",
    *("aten.elu.default", "aten.selu.default", "aten.softplus.default", "aten.gelu.default"),
    *("aten.mish.default", "aten.silu.default", "aten.hardsigmoid.default", "aten.hardswish.default"),
    *("aten.prelu.default", "aten._prelu_kernel.default"),
    "aten.clamp.Tensor",  # reached only to be refused by name (a computed bound)
    "aten.relu6.default",
    "aten.dropout.default",
}
_PURE_PREFIXES = ("aten.add.", "aten.sub.", "aten.mul.", "aten.div.", "aten.rsub.", "aten.neg.", "aten.pow.")
_PURE_OPS = {
    "aten.t.default",
    "aten.permute.default",
    "aten.transpose.int",
    "aten.expand.default",
    "aten.unsqueeze.default",
    "aten.squeeze.dim",
    "aten.squeeze.dims",
    "aten.squeeze.default",
    "aten.ones.default",
    "aten.zeros.default",
    "aten.full.default",
    "aten.ones_like.default",
    "aten.zeros_like.default",
    "aten.full_like.default",
    "aten.scalar_tensor.default",
    "aten.sqrt.default",
    "aten.rsqrt.default",
    "aten.reciprocal.default",
    "aten.lift_fresh_copy.default",
    "aten.slice.Tensor",
    "aten.select.int",
    "aten.cat.default",
    "aten.stack.default",
    "aten.sym_size.int",
}


def known_op(target: Any) -> bool:
    """Whether a call_function target is one seagen reads or a pure constant computation."""
    t = str(target)
    if t in _READ_OPS or t in _PURE_OPS or t.startswith(_PURE_PREFIXES):
        return True
    return t.startswith(("<built-in function ", "<function sym_")) and t != "<built-in function getattr>"


def check_ops(ep: Any, where: str) -> None:
    """Refuse, before any node is evaluated, a graph with an op seagen neither reads nor knows to be pure
    (a node that does not reach the output counts too: the oracle would run it)."""
    for n in ep.graph.nodes:
        if n.op == "call_function" and not known_op(n.target):
            raise refuse(
                where, Item(str(n.target), _path(n)), "unsupported op (checked before anything runs)"
            )


def _name(a: Any) -> str | None:
    """The edge name of an fx.Node argument (None for scalars)."""
    return a.name if hasattr(a, "op") and hasattr(a, "name") else None


def _path(n: Any) -> str:
    """Module path of an fx node (from nn_module_stack) joined with the node name."""
    stack = n.meta.get("nn_module_stack") or {}
    mod = list(stack.values())[-1][0] if stack else ""
    return f"{mod}/{n.name}" if mod else n.name


def _consts(ep: Any) -> dict[str, Any]:
    """Placeholder name -> tensor for every parameter, buffer and lifted constant."""
    sig = ep.graph_signature
    values = {**ep.state_dict, **ep.constants}
    out = {}
    for spec in sig.input_specs:
        if spec.target is not None and spec.target in values:
            out[spec.arg.name] = values[spec.target].detach()
    return out


def _fold(ep: Any, consts: dict[str, Any], where: str) -> None:
    """Evaluate every call whose tensor inputs are all constants (t(), reshape of a weight, ones, ...);
    random ops are left in the graph (and refused)."""
    import torch.fx

    for n in ep.graph.nodes:
        if n.op != "call_function":
            continue
        names = [x.name for x in n.all_input_nodes]
        random = torch.Tag.nondeterministic_seeded in getattr(n.target, "tags", ())
        if all(x in consts for x in names) and not random:
            args, kwargs = torch.fx.node.map_arg((n.args, n.kwargs), lambda a: consts[a.name])
            try:
                consts[n.name] = n.target(*args, **kwargs)
            except Exception as e:  # any op can fail on odd inputs
                raise UserError(f"{where}: {_path(n)} ({n.target}): cannot evaluate constant: {e}") from None


def exported_items(ep: Any, where: str) -> tuple[list[Item], int]:
    """The op chain of an ExportedProgram and its input width."""
    check_ops(ep, where)
    consts = _consts(ep)
    _fold(ep, consts, where)
    users = [s.arg.name for s in ep.graph_signature.input_specs if s.kind.name == "USER_INPUT"]
    outs = [s.arg.name for s in ep.graph_signature.output_specs if s.kind.name == "USER_OUTPUT"]
    joined = joined_inputs(ep, where) if len(users) > 1 else None  # inputs concatenated into one vector
    if (len(users) != 1 and joined is None) or len(outs) != 1:
        raise UserError(
            f"{where}: the program has {len(users)} inputs and {len(outs)} outputs; "
            "seagen exports one input tensor (or inputs it concatenates first) and one output"
        )
    start = joined[0] if joined else users[0]
    ph = next(n for n in ep.graph.nodes if n.name == start)
    shape = tuple(ph.meta["val"].shape)
    if len(shape) != 2:
        raise UserError(f"{where}: input '{start}' has shape {shape}; seagen needs (batch, features)")
    fx = {n.name: n for n in ep.graph.nodes}
    nodes = [
        Node(str(n.target), _path(n), _inputs(n), [n.name], raw=n)
        for n in ep.graph.nodes
        if n.op == "call_function" and n.name not in consts
    ]
    chain = chain_nodes(nodes, set(consts), start, outs[0], where)
    items = [it for n in chain for it in _item(n.raw, consts, fx, where)]
    return items, int(shape[1])


def _keeps_rows(n: Any) -> bool:
    """A view/reshape whose input and output are both (batch, k) of the same sizes (e.g.
    x.view(x.shape[0], -1) on a dynamic batch): every row stays as it is, whatever computed the sizes."""
    if str(n.target) not in _VIEWS or not n.args or _name(n.args[0]) is None:
        return False
    a, b = getattr(n.args[0].meta.get("val"), "shape", None), getattr(n.meta.get("val"), "shape", None)
    return a is not None and b is not None and len(a) == 2 and [str(d) for d in a] == [str(d) for d in b]


def _inputs(n: Any) -> list[str]:
    """The edges an fx node reads: a row-keeping view reads only its tensor (its sizes are bookkeeping)."""
    return [n.args[0].name] if _keeps_rows(n) else [a.name for a in n.all_input_nodes]


def _arg(n: Any, k: int, key: str, default: Any, consts: dict) -> Any:
    """Argument k (or keyword key) of an fx node, constants resolved to numpy."""
    a = n.args[k] if len(n.args) > k else n.kwargs.get(key, default)
    nm = _name(a)
    if nm is not None:
        return consts[nm].double().numpy() if nm in consts else a
    return a


def _item(n: Any, consts: dict, fx: dict, where: str) -> list[Item]:
    """One ATen call -> zero or more chain items; anything unsupported is refused."""
    t, p = str(n.target), _path(n)
    if t in _DENSE:
        return [_dense(n, t, p, consts, where)]
    if t.startswith(("aten.add.", "aten.sub.", "aten.mul.", "aten.div.", "aten.rsub.")):
        return [_arith(n, t, p, consts, where)]
    if t in _ACTS:
        return [Act(t, p, _ACTS[t])]
    if t == "aten.leaky_relu.default":
        return [Act(t, p, "leaky_relu", alpha=float(_arg(n, 1, "negative_slope", 0.01, consts)))]
    if t in _SMOOTH:
        return [_smooth(n, t, p, consts, where)]
    if t in _CLAMPS:
        return [_clamp(n, t, p, consts, where)]
    if t == "aten.relu6.default":
        return [clip_act(t, p, 0.0, 6.0)]
    if t in _BATCHNORM:
        return [_batchnorm(n, t, p, consts, where)]
    if t in _NOOPS and (t != "<built-in function getitem>" or n.args[1] == 0):
        return []
    if t == "aten.dropout.default":
        if _arg(n, 2, "train", False, consts) and _arg(n, 1, "p", 0.5, consts) != 0:
            raise refuse(
                where, Item(t, p), "Dropout in training mode (random at inference; export in eval mode)"
            )
        return []
    if t in _CASTS:
        dtype = n.kwargs.get("dtype", n.args[1] if len(n.args) > 1 else None)
        if str(dtype) in _FLOATS:
            return []
    if _keeps_rows(n):
        return []
    if t in _VIEWS:
        shape = list(n.args[1])
        if len(shape) == 2 and all(isinstance(s, int) for s in shape):
            return [Reshape(t, p, int(shape[1]))]
    raise refuse(where, Item(t, p), "unsupported op")


def _dense(n: Any, t: str, p: str, consts: dict, where: str) -> Dense:
    """linear(x, W, b), addmm(b, x, W^T), mm/matmul(x, W) with constant weights."""
    if t == "aten.linear.default":
        w = _arg(n, 1, "weight", None, consts)
        b = _arg(n, 2, "bias", None, consts)
    elif t == "aten.addmm.default":  # beta * b + alpha * (x @ W^T)
        b, w = _arg(n, 0, "self", None, consts), _arg(n, 2, "mat2", None, consts)
        beta, alpha = _scalar_kw(n, "beta", t, p, where), _scalar_kw(n, "alpha", t, p, where)
        w = w.T * alpha if isinstance(w, np.ndarray) else w
        b = b * beta if isinstance(b, np.ndarray | float | int) else b
    else:
        w = _arg(n, 1, "other", None, consts)
        w = w.T if isinstance(w, np.ndarray) else w
        b = None
    if (
        not isinstance(w, np.ndarray)
        or w.ndim != 2
        or not (b is None or isinstance(b, np.ndarray | float | int))
    ):
        raise refuse(where, Item(t, p), "the weight or bias is not a constant")
    b = np.zeros(w.shape[0]) if b is None else np.broadcast_to(np.asarray(b).reshape(-1), (w.shape[0],))
    return Dense(t, p, w, np.array(b, dtype=float))


def _scalar_kw(n: Any, key: str, t: str, p: str, where: str) -> float:
    """A keyword scale of an ATen call (addmm's alpha/beta), 1 when absent; anything but a finite number is
    refused."""
    v = n.kwargs.get(key, 1.0)
    if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
        raise refuse(where, Item(t, p), f"{key}={v!r} is not a finite number")
    return float(v)


def _same_operands(n: Any, t: str, p: str, where: str) -> Affine:
    """x + x, x - x, rsub(x, x): the scale they are; x * x and x / x are refused by name."""
    op = t.split(".")[1]
    alpha = float(n.kwargs.get("alpha", n.args[2] if len(n.args) > 2 else 1.0))
    x = _name(n.args[0])
    if op == "add":
        return Affine(t, p, np.array(1.0 + alpha), np.array(0.0))
    if op in ("sub", "rsub"):
        return Affine(t, p, np.array(1.0 - alpha), np.array(0.0))
    what = "a product" if op == "mul" else "a quotient"
    raise refuse(
        where,
        Item(t, p),
        f"{what} of two computed values ({x} {'*' if op == 'mul' else '/'} {x}) is not affine",
    )


def _arith(n: Any, t: str, p: str, consts: dict, where: str) -> Affine:
    """add/sub/mul/div/rsub by a constant (tensor or scalar) as an elementwise affine map."""
    names = [_name(a) for a in n.args[:2]]
    if len(names) == 2 and names[0] is not None and names[0] == names[1] and names[0] not in consts:
        return _same_operands(n, t, p, where)
    first_computed = _name(n.args[0]) is not None and _name(n.args[0]) not in consts
    c_arg = _arg(n, 1 if first_computed else 0, "other", None, consts)
    if _name(c_arg) is not None or c_arg is None:
        raise refuse(where, Item(t, p), "an operand that is neither a constant nor the one computed input")
    c = np.asarray(c_arg, dtype=float)
    alpha = float(n.kwargs.get("alpha", n.args[2] if len(n.args) > 2 else 1.0))
    one, zero = np.ones_like(c), np.zeros_like(c)
    op = t.split(".")[1]
    if op == "rsub":
        op, first_computed = "sub", not first_computed
    if op == "add":  # add(x, c, alpha) = x + alpha c; add(c, x, alpha) = c + alpha x
        return Affine(t, p, one, c * alpha) if first_computed else Affine(t, p, one * alpha, c)
    if op == "mul":
        return Affine(t, p, c, zero)
    if op == "sub":
        return Affine(t, p, one, -c * alpha) if first_computed else Affine(t, p, -one * alpha, c)
    if first_computed and np.all(c != 0) and not n.kwargs.get("rounding_mode"):
        return Affine(t, p, 1.0 / c, zero)
    raise refuse(where, Item(t, p), "division by a computed value, by zero or with rounding")


def _smooth(n: Any, t: str, p: str, consts: dict, where: str) -> Act:
    """elu(alpha, scale, input_scale), selu, softplus(beta, threshold), gelu(approximate), mish, silu,
    hardsigmoid, hardswish, prelu(weight): the IR activation with torch's parameters."""
    if t == "aten.elu.default":
        alpha, scale = (float(_arg(n, k, key, 1.0, consts)) for k, key in ((1, "alpha"), (2, "scale")))
        if scale != 1.0 or float(_arg(n, 3, "input_scale", 1.0, consts)) != 1.0:
            if (alpha, scale) != (SELU[0], SELU[1]):
                raise refuse(where, Item(t, p), "elu with a scale or input_scale other than SELU's")
            return Act(t, p, "selu", params=SELU)
        return Act(t, p, "elu", params=(alpha,))
    if t == "aten.softplus.default":
        beta, th = float(_arg(n, 1, "beta", 1.0, consts)), float(_arg(n, 2, "threshold", 20.0, consts))
        return Act(t, p, "softplus", params=(beta, th))
    if t == "aten.gelu.default":
        approx = n.kwargs.get("approximate", "none")
        if approx not in ("none", "tanh"):
            raise refuse(where, Item(t, p), f"approximate={approx!r}")
        return Act(t, p, "gelu" if approx == "none" else "gelu_tanh")
    if t in ("aten.prelu.default", "aten._prelu_kernel.default"):
        w = _arg(n, 1, "weight", None, consts)
        if not isinstance(w, np.ndarray):
            raise refuse(where, Item(t, p), "the PReLU weight is not a constant")
        return Act(t, p, "prelu", params=tuple(float(v) for v in w.reshape(-1)))
    if t == "aten.hardsigmoid.default":
        return Act(t, p, "hardsigmoid", params=(1.0 / 6.0, 0.5))
    return Act(t, p, _SMOOTH[t], params=SELU if t == "aten.selu.default" else ())


def _clamp(n: Any, t: str, p: str, consts: dict, where: str) -> Act:
    """hardtanh(lo, hi), clamp(min, max), clamp_min, clamp_max -> relu or hardtanh (bounds must be numbers
    or one-element constants)."""
    for a in (*n.args[1:], *n.kwargs.values()):
        nm = _name(a)
        if nm is not None and (nm not in consts or consts[nm].numel() != 1):
            raise refuse(where, Item(t, p), f"the bound '{nm}' is not one constant number")
    if t == "aten.hardtanh.default":
        return clip_act(t, p, _arg(n, 1, "min_val", -1.0, consts), _arg(n, 2, "max_val", 1.0, consts))
    if t == "aten.clamp_min.default":
        return clip_act(t, p, _arg(n, 1, "min", None, consts), None)
    if t == "aten.clamp_max.default":
        return clip_act(t, p, None, _arg(n, 1, "max", None, consts))
    return clip_act(t, p, _arg(n, 1, "min", None, consts), _arg(n, 2, "max", None, consts))


def _batchnorm(n: Any, t: str, p: str, consts: dict, where: str) -> Affine:
    """BatchNorm in eval mode (running statistics) as an elementwise affine map."""
    if t == "aten.batch_norm.default" and _arg(n, 5, "training", False, consts):
        raise refuse(where, Item(t, p), "BatchNorm in training mode")
    eps_k = 7 if t == "aten.batch_norm.default" else 6
    g, b, m, v = (_arg(n, k, "", None, consts) for k in (1, 2, 3, 4))
    if any(not isinstance(a, np.ndarray) for a in (g, b, m, v)):
        raise refuse(where, Item(t, p), "BatchNorm without affine parameters and running statistics")
    return batchnorm_affine(t, p, g, b, m, v, float(n.args[eps_k]))


def sequential_items(m: Any) -> list[Item] | None:
    """A plain nn.Sequential of known torch.nn layers, read layer by layer (exactly what its forward does);
    None for anything else (custom forward, subclasses, other layers), which goes through torch.export."""
    import torch.nn as nn

    if type(m) is not nn.Sequential:
        return None
    items: list[Item] = []
    linears = [id(c) for _, c in m.named_modules(remove_duplicate=False) if type(c) is nn.Linear]
    if len(linears) != len(set(linears)):
        return None  # a Linear used twice: torch.export sees it and refuses
    for name, child in m.named_children():
        c: Any = child
        p, t = name, type(c).__name__
        if type(c) is nn.Sequential:
            sub = sequential_items(c)
            if sub is None:
                return None
            items += sub
        elif type(c) is nn.Linear:
            b = c.bias.detach().double().numpy() if c.bias is not None else np.zeros(c.out_features)
            items.append(Dense(t, p, c.weight.detach().double().numpy(), b))
        elif type(c) in (nn.ReLU, nn.Tanh, nn.Sigmoid):
            items.append(Act(t, p, {"ReLU": "relu", "Tanh": "tanh", "Sigmoid": "sigmoid"}[t]))
        elif type(c) is nn.LeakyReLU:
            items.append(Act(t, p, "leaky_relu", alpha=float(c.negative_slope)))
        elif (act := _smooth_module(c)) is not None:
            items.append(Act(t, p, act[0], params=act[1]))
        elif type(c) in (nn.Hardtanh, nn.ReLU6):
            items.append(clip_act(t, p, float(c.min_val), float(c.max_val)))
        elif type(c) in (nn.Identity, nn.Dropout) or (type(c) is nn.Flatten and c.start_dim == 1):
            continue
        elif type(c) is nn.BatchNorm1d and c.track_running_stats and c.running_mean is not None:
            items.append(_bn_module(c, t, p))
        else:
            return None
    return items


def _smooth_module(c: Any) -> tuple[str, tuple[float, ...]] | None:
    """(IR activation, params) of a torch.nn smooth or piecewise-linear activation module, else None."""
    import torch.nn as nn

    if type(c) is nn.ELU:
        return "elu", (float(c.alpha),)
    if type(c) is nn.SELU:
        return "selu", SELU
    if type(c) is nn.Softplus:
        return "softplus", (float(c.beta), float(c.threshold))
    if type(c) is nn.GELU and c.approximate in ("none", "tanh"):
        return ("gelu" if c.approximate == "none" else "gelu_tanh"), ()
    if type(c) is nn.PReLU:
        return "prelu", tuple(float(v) for v in c.weight.detach().double().numpy().reshape(-1))
    if type(c) is nn.Hardsigmoid:
        return "hardsigmoid", (1.0 / 6.0, 0.5)
    names = {nn.Mish: "mish", nn.SiLU: "silu", nn.Hardswish: "hardswish"}
    return (names[type(c)], ()) if type(c) in names else None


def _bn_module(c: Any, t: str, p: str) -> Affine:
    """An eval-mode BatchNorm1d module as an elementwise affine map."""
    v, mu = c.running_var.detach().double().numpy(), c.running_mean.detach().double().numpy()
    g = c.weight.detach().double().numpy() if c.affine else np.ones_like(v)
    b = c.bias.detach().double().numpy() if c.affine else np.zeros_like(v)
    return batchnorm_affine(t, p, g, b, mu, v, c.eps)
