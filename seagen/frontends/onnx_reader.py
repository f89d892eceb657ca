"""ONNX graph -> op chain, read by its edges (tensor names) from the graph input to the graph output."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from seagen.errors import UserError
from seagen.frontends.chain import Act, Affine, Dense, Item, Reshape, batchnorm_affine, clip_act, refuse
from seagen.frontends.graph import Node, chain_nodes
from seagen.frontends.onnx_batch import batch_reshapes
from seagen.frontends.onnx_patterns import FUSED_OP, fuse_regions
from seagen.frontends.onnx_shapes import (
    SHAPE_OPS,
    B,
    Feed,
    Shape,
    after,
    concat_inputs,
    declared,
    shape_text,
    shape_text_of,
)

_ACTS = {"Relu": "relu", "Tanh": "tanh", "Sigmoid": "sigmoid"}
_NOOPS = ("Identity", "Dropout")
_SMOOTH_OPS = ("Elu", "Selu", "Softplus", "Gelu", "Mish", "HardSigmoid", "HardSwish", "PRelu")
_SELU = (1.67326319217681884765625, 1.05070102214813232421875)  # ONNX Selu's default alpha, gamma
# TensorProto FLOAT, DOUBLE, FLOAT16, BFLOAT16: a Cast to one is read as the identity (the original's margin
# is that of the narrowest float type in the graph: seagen.frontends.onnx_dtype)
_FLOAT = (1, 11, 10, 16)
_ENDS = (*SHAPE_OPS, "Identity", "Cast")  # what a converter writes between the graph's ends and the network


def _fold_constants(model: Any, nodes: list[Node], where: str) -> dict[str, np.ndarray]:
    """Initializers and every node whose inputs are all constant, evaluated once (onnx reference runtime)."""
    from onnx import numpy_helper

    consts = {t.name: numpy_helper.to_array(t) for t in model.graph.initializer}
    todo = list(nodes)
    while True:  # to a fixed point: nodes need not be listed in order
        ready = [
            n
            for n in todo
            if n.op == "Constant" or (n.inputs and all(i in consts or not i for i in n.inputs))
        ]
        if not ready:
            return consts
        for n in ready:
            try:
                vals = _run_node(model, n.raw, consts)
            except Exception as e:  # the reference runtime raises many types
                raise UserError(f"{where}: {n.path} ({n.op}): cannot evaluate constant node: {e}") from None
            consts.update(zip(n.outputs, vals, strict=False))
        todo = [n for n in todo if n not in ready]


def _run_node(model: Any, node: Any, consts: dict[str, np.ndarray]) -> list[np.ndarray]:
    """One node on constant inputs through onnx.reference."""
    from onnx import helper, numpy_helper
    from onnx.reference import ReferenceEvaluator

    ins = [numpy_helper.from_array(np.asarray(consts[i]), i) for i in node.input if i]
    outs = [helper.make_tensor_value_info(o, 0, None) for o in node.output]
    g = helper.make_graph([node], "c", [], outs, ins)
    m = helper.make_model(g, opset_imports=model.opset_import, ir_version=model.ir_version)
    return list(ReferenceEvaluator(m).run(None, {}))


def onnx_items(path: Path, model: Any) -> tuple[list[Item], int, Feed]:
    """The model's op chain, its input width and how its original takes rows."""
    import onnx

    where = str(path)
    g = model.graph
    nodes = [
        Node(
            n.op_type,
            n.name or n.output[0],
            list(n.input),
            list(n.output),
            {a.name: onnx.helper.get_attribute_value(a) for a in n.attribute},
            n,
        )
        for n in g.node
    ]
    consts = _fold_constants(model, nodes, where)
    nodes = fuse_regions(model, nodes, consts)  # GELU's erf form, x * sigmoid(x), ... as one activation
    inputs = [i for i in g.input if i.name not in consts]
    cat = concat_inputs(nodes, inputs, where) if len(inputs) > 1 else None  # inputs joined into one vector
    if (len(inputs) != 1 and cat is None) or len(g.output) != 1:
        names = ", ".join(i.name for i in inputs)
        raise UserError(
            f"{where}: the graph has {len(inputs)} inputs ({names}) and {len(g.output)} outputs; "
            "seagen exports one input tensor (a weight must be an initializer) and one output"
        )
    vi, parts = cat if cat is not None else (inputs[0], ())
    batch_reshapes(nodes, consts, vi)  # x.view(x.shape[0], -1)
    chain = chain_nodes(nodes, set(consts), vi.name, g.output[0].name, where)
    items, width, feed = _read_chain(chain, consts, where, vi)
    return items, width, dataclasses.replace(feed, parts=parts)


def _read_chain(chain: list[Node], consts: dict, where: str, vi: Any) -> tuple[list[Item], int, Feed]:
    """The chain's items; the shape-only nodes at its ends (batch bookkeeping, onnx_shapes) followed on the
    shapes: the network between them must take (batch, features) and give whole rows."""
    shape = given = declared(vi, where)
    items: list[Item] = []
    k = 0
    while k < len(chain) and chain[k].op in _ENDS:
        shape = _end_node(chain[k], shape, consts, where, items)
        k += 1
    if len(shape) != 2 or shape[1] == B:
        reshaped = f", reshaped to {shape_text_of(shape)}," if k else ""
        raise UserError(
            f"{where}: input '{vi.name}' has shape {shape_text(vi)}{reshaped}; seagen needs (batch, features)"
        )
    feed = Feed(vi.name, given, None if shape[0] == B else shape[0])
    j = len(chain)
    while j > k and chain[j - 1].op in _ENDS:
        j -= 1
    for n in chain[k:j]:
        items.extend(_item(n, consts, where, -1 if shape[0] == B else shape[0]))
    width = next((it.weight.shape[0] for it in reversed(items) if isinstance(it, Dense)), None)
    out: Shape = (shape[0], width or 1)
    for n in chain[j:]:
        out = _end_node(n, out, consts, where, items)
    return items, shape[1], feed


def _end_node(n: Node, shape: Shape, consts: dict, where: str, items: list[Item]) -> Shape:
    """A node at an end of the chain: a shape-only node changes the tracked shape; Identity or a Cast to a
    float type is read as any other node (it keeps the shape)."""
    if n.op in SHAPE_OPS:
        return after(n, shape, consts, where)
    items.extend(_item(n, consts, where))
    return shape


def _c(n: Node, consts: dict, k: int, where: str = "") -> np.ndarray | None:
    """Constant input k of a node (None when absent); a computed one is refused."""
    if len(n.inputs) <= k or not n.inputs[k]:
        return None
    if n.inputs[k] not in consts:
        raise refuse(where, Item(n.op, n.path), f"input {k} ('{n.inputs[k]}') is computed, not a constant")
    return np.asarray(consts[n.inputs[k]], dtype=float)


def _bound(n: Node, consts: dict, k: int, attr: str, where: str) -> float | None:
    """A Clip bound: input k (shape () or (1,), as onnxruntime accepts) or the opset < 11 attribute."""
    v = _c(n, consts, k, where)
    if v is None:
        return n.attrs.get(attr)
    if v.size != 1:
        raise refuse(where, Item(n.op, n.path), f"clip bound of shape {v.shape} (needs one number)")
    return float(v.reshape(-1)[0])


def _item(n: Node, consts: dict, where: str, batch: int = -1) -> list[Item]:
    """One chain node -> zero or more chain items; anything unsupported is refused."""
    op, p, a = n.op, n.path, n.attrs
    if op == "Gemm":
        return [_gemm(n, consts, where)]
    if op in ("Add", "Sub", "Mul", "Div", "MatMul") and len(n.inputs) == 2 and n.inputs[0] == n.inputs[1]:
        return [_same_operands(n, where)]
    if op == "MatMul" and n.inputs[1] in consts:
        w = _c(n, consts, 1, where)
        assert w is not None
        if w.ndim != 2:
            raise refuse(where, Item(op, p), f"weight of shape {w.shape}")
        return [Dense(op, p, w.T, np.zeros(w.shape[1]))]
    if op in ("Add", "Sub", "Mul", "Div"):
        return [_arith(n, consts, where)]
    if op in _ACTS:
        return [Act(op, p, _ACTS[op])]
    if op == "LeakyRelu":
        return [Act(op, p, "leaky_relu", alpha=float(a.get("alpha", 0.01)))]
    if op in _SMOOTH_OPS or op == FUSED_OP:
        return [_smooth(n, consts, where)]
    if op == "Clip":
        return [clip_act(op, p, _bound(n, consts, 1, "min", where), _bound(n, consts, 2, "max", where))]
    if op in ("Max", "Min"):
        return _minmax(n, consts, where)
    if op == "BatchNormalization" and not a.get("training_mode", 0):
        g_, b_, m_, v_ = (_c(n, consts, k, where) for k in (1, 2, 3, 4))
        return [batchnorm_affine(op, p, g_, b_, m_, v_, float(a.get("epsilon", 1e-5)))]
    if op == "Dropout" and _dropout_trains(n, consts, where):
        raise refuse(where, Item(op, p), "Dropout in training mode (random at inference)")
    if op == "BatchNormalization":
        raise refuse(where, Item(op, p), "BatchNormalization in training mode")
    return _passing(n, consts, where, batch)


def _smooth(n: Node, consts: dict, where: str) -> Act:
    """The smooth and piecewise-linear activation ops with ONNX's defaults, PRelu's constant slopes, and the
    regions onnx_patterns recognised."""
    op, p, a = n.op, n.path, n.attrs
    if op == FUSED_OP:
        return Act(f"{a['form']}", p, a["kind"], params=tuple(a["params"]))
    if op == "Elu":
        return Act(op, p, "elu", params=(float(a.get("alpha", 1.0)),))
    if op == "Selu":
        return Act(op, p, "selu", params=(float(a.get("alpha", _SELU[0])), float(a.get("gamma", _SELU[1]))))
    if op == "Softplus":
        return Act(op, p, "softplus", params=(1.0, float("inf")))
    if op == "Gelu":
        approx = a.get("approximate", "none")
        approx = approx.decode() if isinstance(approx, bytes) else approx
        if approx not in ("none", "tanh"):
            raise refuse(where, Item(op, p), f"approximate={approx!r} (ONNX defines none and tanh)")
        return Act(op, p, "gelu" if approx == "none" else "gelu_tanh")
    if op == "HardSigmoid":
        return Act(op, p, "hardsigmoid", params=(float(a.get("alpha", 0.2)), float(a.get("beta", 0.5))))
    if op == "PRelu":
        slope = _c(n, consts, 1, where)
        assert slope is not None
        if slope.size > 1 and slope.shape[-1] != slope.size:
            raise refuse(where, Item(op, p), f"slope of shape {slope.shape} (one per feature, or one)")
        return Act(op, p, "prelu", params=tuple(float(v) for v in slope.reshape(-1)))
    return Act(op, p, {"Mish": "mish", "HardSwish": "hardswish"}[op])


def _passing(n: Node, consts: dict, where: str, batch: int) -> list[Item]:
    """Nodes that pass values on: Identity, Dropout (inference), a Cast to a float type, Flatten(axis=1), a
    Reshape to (batch, width); anything else is refused."""
    op, p, a = n.op, n.path, n.attrs
    if op in _NOOPS or (op == "Cast" and a.get("to") in _FLOAT):
        return []
    if op == "Cast":
        raise refuse(
            where, Item(op, p), f"a cast to {_type_name(a.get('to'))} (casts to a float type are read)"
        )
    if op == "Flatten" and int(a.get("axis", 1)) == 1:
        return []
    if op == "Reshape":
        shape = _c(n, consts, 1, where)
        if shape is not None and shape.size == 2 and shape[0] in (-1, 0, batch):
            return [Reshape(op, p, int(shape[1]))]
    raise refuse(where, Item(op, p), "unsupported op")


def _type_name(t: Any) -> str:
    """An ONNX element type by name (INT32), or as given when it is not one."""
    from onnx import TensorProto

    try:
        return TensorProto.DataType.Name(int(t))
    except (TypeError, ValueError):
        return repr(t)


def _minmax(n: Node, consts: dict, where: str) -> list[Item]:
    """Max/Min of the computed input and constant numbers as the clip it is (jax2onnx writes ReLU as
    Max(x, 0)); with no constant (Max(x), Max(x, x)) the identity."""
    vals = [np.asarray(consts[i], dtype=float) for i in n.inputs if i in consts]
    if any(v.size != 1 or v.ndim > 2 for v in vals):
        shapes = ", ".join(str(v.shape) for v in vals)
        raise refuse(where, Item(n.op, n.path), f"constant of shape {shapes} (read as a clip: one number)")
    bounds = [float(v.reshape(-1)[0]) for v in vals]
    if any(np.isnan(b) for b in bounds):
        raise refuse(where, Item(n.op, n.path), "a NaN constant")
    if not bounds:
        return []
    if n.op == "Max":
        return [clip_act(n.op, n.path, max(bounds), None)]
    return [clip_act(n.op, n.path, None, min(bounds))]


def _dropout_trains(n: Node, consts: dict, where: str) -> bool:
    """Dropout (opset 12+) whose constant training_mode input is true and whose ratio is not 0; opset < 7
    Dropout with is_test=0 likewise."""
    mode = _c(n, consts, 2, where)
    ratio = _c(n, consts, 1, where)
    r = float(n.attrs.get("ratio", 0.5)) if ratio is None else float(ratio.reshape(-1)[0])
    training = bool(mode is not None and mode.reshape(-1)[0]) or n.attrs.get("is_test", 1) == 0
    return training and r != 0.0


def _gemm(n: Node, consts: dict, where: str) -> Dense:
    """Gemm in every attribute form: Y = alpha * A' B' + beta * C with the computed input as A."""
    a = n.attrs
    item = Item("Gemm", n.path)
    if n.inputs[0] in consts or n.inputs[1] not in consts or a.get("transA", 0):
        raise refuse(where, item, "the computed input must be A (transA=0) and B a constant")
    w = _c(n, consts, 1, where)
    assert w is not None
    w = w if a.get("transB", 0) else w.T
    c = _c(n, consts, 2, where)
    c = np.zeros(w.shape[0]) if c is None else c
    if c.size not in (1, w.shape[0]) or (c.ndim == 2 and c.shape[0] != 1) or c.ndim > 2:
        raise refuse(where, item, f"bias of shape {c.shape} for {w.shape[0]} outputs")
    b = np.broadcast_to(c.reshape(-1), (w.shape[0],)) * float(a.get("beta", 1.0))
    return Dense("Gemm", n.path, w * float(a.get("alpha", 1.0)), b.copy())


def _same_operands(n: Node, where: str) -> Affine:
    """Add(x, x) is a scale of 2, Sub(x, x) of 0; a product or quotient of two computed values is refused."""
    if n.op == "Add":
        return Affine(n.op, n.path, np.array(2.0), np.array(0.0))
    if n.op == "Sub":
        return Affine(n.op, n.path, np.array(0.0), np.array(0.0))
    what, sym = {"Mul": ("a product", "*"), "MatMul": ("a product", "@"), "Div": ("a quotient", "/")}[n.op]
    x = n.inputs[0]
    raise refuse(where, Item(n.op, n.path), f"{what} of two computed values ({x} {sym} {x}) is not affine")


def _arith(n: Node, consts: dict, where: str) -> Affine:
    """Add/Sub/Mul/Div by a constant as an elementwise affine map (constant / x is refused)."""
    op, p = n.op, n.path
    k = 0 if n.inputs[0] in consts else 1
    c = np.asarray(consts[n.inputs[k]], dtype=float)
    one, zero = np.ones_like(c), np.zeros_like(c)
    if op == "Add":
        return Affine(op, p, one, c)
    if op == "Mul":
        return Affine(op, p, c, zero)
    if op == "Sub":
        return Affine(op, p, one, -c) if k == 1 else Affine(op, p, -one, c)
    if k == 1 and np.all(c != 0):
        return Affine(op, p, 1.0 / c, zero)
    raise refuse(where, Item(op, p), "division by a computed value or by zero")
