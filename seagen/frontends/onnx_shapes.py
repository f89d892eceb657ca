"""The batch bookkeeping converters write at the ends of an ONNX graph: shape-only nodes (Unsqueeze, Squeeze,
Reshape, Flatten) between the graph input and the network's (rows, features), and between its (rows, 1) and
the graph output. Each is followed on the shapes, with the open batch dimension kept symbolic, and read
only when it relabels whole rows in order: it moves no value from one row to another."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from seagen.errors import UserError
from seagen.frontends.chain import Item, refuse
from seagen.frontends.graph import Node

B = -2  # the open batch dimension (symbolic or unknown in the graph); -1 is Reshape's "the rest"
SHAPE_OPS = ("Unsqueeze", "Squeeze", "Reshape", "Flatten")
Shape = tuple[int, ...]


@dataclass(frozen=True)
class Feed:
    """How the original takes rows: its input's name and shape (B for the open batch dimension), and the
    rows of one run when it has no open dimension (one sample of a (features,) input, a fixed batch)."""

    name: str
    shape: Shape
    rows: int | None  # None: any number of rows in one run
    parts: tuple[tuple[str, int], ...] = ()  # graph inputs concatenated into this one: (name, width) in order

    def layout(self, n: int) -> Shape:
        """The input shape for a run of n rows."""
        return tuple(n if d == B else d for d in self.shape)


def shape_text(value_info: Any) -> str:
    """A graph input's shape as ONNX declares it: numbers, symbolic dimensions by name, '?' when unknown."""
    dims = value_info.type.tensor_type.shape.dim
    return (
        "["
        + ", ".join(d.dim_param or (str(d.dim_value) if d.HasField("dim_value") else "?") for d in dims)
        + "]"
    )


def declared(value_info: Any, where: str) -> Shape:
    """The graph input's shape: its fixed sizes, B for a symbolic or unknown one (at most one, after sizes 1
    only, so the rows lie in order)."""
    dims = value_info.type.tensor_type.shape.dim
    shape = tuple(d.dim_value if d.HasField("dim_value") and d.dim_value > 0 else B for d in dims)
    if not shape or not _rows_in_order(shape):
        raise UserError(
            f"{where}: input '{value_info.name}' has shape {shape_text(value_info)}; seagen needs "
            "(batch, features), or a shape the graph reshapes to it with the batch as the leading axis"
        )
    return shape


def concat_inputs(nodes: list[Node], inputs: list[Any], where: str) -> tuple[Any, tuple] | None:
    """A Concat along the features of exactly the graph's inputs (each once, all (batch, width) with the same
    batch), read as one input: the value info of its output, (batch, sum of widths), and the parts (name,
    width) in the Concat's order; None when no node concatenates all the inputs."""
    from onnx import helper

    vis = {i.name: i for i in inputs}
    cat = next((n for n in nodes if n.op == "Concat" and sorted(n.inputs) == sorted(vis)), None)
    if cat is None:
        return None
    shapes = [declared(vis[i], where) for i in cat.inputs]
    rows = {s[0] for s in shapes}
    if cat.attrs.get("axis") not in (1, -1) or any(len(s) != 2 or s[1] == B for s in shapes) or len(rows) > 1:
        why = "concatenates the graph inputs other than along the features of (batch, width) inputs"
        raise refuse(where, Item(cat.op, cat.path), why)
    batch = "N" if B in rows else rows.pop()
    elem = vis[cat.inputs[0]].type.tensor_type.elem_type
    vi = helper.make_tensor_value_info(cat.outputs[0], elem, [batch, sum(s[1] for s in shapes)])
    return vi, tuple((i, s[1]) for i, s in zip(cat.inputs, shapes, strict=True))


def split_parts(feed: Feed, x: np.ndarray) -> dict[str, np.ndarray]:
    """The graph's input feed for rows x laid out as feed: x itself, or its columns split into the inputs a
    Concat joins."""
    if not feed.parts:
        return {feed.name: x}
    cuts = np.cumsum([w for _, w in feed.parts])[:-1]
    cols = np.split(x, cuts, axis=1)
    return {name: np.ascontiguousarray(c) for (name, _), c in zip(feed.parts, cols, strict=True)}


def _rows_in_order(shape: Shape) -> bool:
    """At most one open dimension, with only sizes 1 before it."""
    if shape.count(B) > 1:
        return False
    return B not in shape or math.prod(shape[: shape.index(B)]) == 1


def after(n: Node, shape: Shape, consts: dict[str, np.ndarray], where: str) -> Shape:
    """The shape after one shape-only node; a node that would move values across rows, or whose result
    depends on the number of rows, is refused."""
    item = Item(n.op, n.path)
    out: Shape
    if n.op == "Flatten":
        axis = int(n.attrs.get("axis", 1))
        axis = _axis(axis, len(shape) + 1, item, where) if axis >= 0 else _axis(axis, len(shape), item, where)
        out = (_product(shape[:axis], item, where), _product(shape[axis:], item, where))
    elif n.op == "Unsqueeze":
        axes = node_axes(n, consts, where)
        grown = list(shape)
        for a in sorted(_axis(a, len(shape) + len(axes), item, where) for a in axes):
            grown.insert(a, 1)
        out = tuple(grown)
    elif n.op == "Squeeze":
        out = _squeeze(n, shape, consts, where)
    else:
        out = _reshape(n, shape, consts, where)
    if not _rows_in_order(out):
        raise refuse(where, item, f"{shape_text_of(shape)} -> {shape_text_of(out)} moves the batch axis")
    return out


def shape_text_of(shape: Shape) -> str:
    """A tracked shape, the open batch dimension as N."""
    return "[" + ", ".join("N" if d == B else str(d) for d in shape) + "]"


def node_axes(n: Node, consts: dict[str, np.ndarray], where: str) -> list[int]:
    """Unsqueeze/Squeeze axes: the attribute (opset < 13) or the constant second input; [] when absent."""
    if "axes" in n.attrs:
        return [int(a) for a in n.attrs["axes"]]
    if len(n.inputs) < 2 or not n.inputs[1]:
        return []
    if n.inputs[1] not in consts:
        raise refuse(where, Item(n.op, n.path), "axes computed, not a constant")
    return [int(a) for a in np.asarray(consts[n.inputs[1]]).reshape(-1)]


def _axis(a: int, rank: int, item: Item, where: str) -> int:
    """An axis in [-rank, rank) as a non-negative index."""
    if not -rank <= a < rank:
        raise refuse(where, item, f"axis {a} of a rank-{rank} result")
    return a % rank


def _product(dims: Shape, item: Item, where: str) -> int:
    """The size of merged dimensions: B only when the others are all 1 (else rows and features would mix)."""
    if B not in dims:
        return math.prod(dims)
    if math.prod(d for d in dims if d != B) != 1:
        raise refuse(where, item, f"merges the batch axis with features ({shape_text_of(dims)})")
    return B


def _squeeze(n: Node, shape: Shape, consts: dict[str, np.ndarray], where: str) -> Shape:
    """Squeeze of axes of size 1 (all of them when none are given); never of the open batch axis."""
    item = Item(n.op, n.path)
    axes = {_axis(a, len(shape), item, where) for a in node_axes(n, consts, where)}
    if not axes:
        if B in shape:
            raise refuse(where, item, "Squeeze without axes of a tensor with an open batch axis")
        axes = {i for i, d in enumerate(shape) if d == 1}
    for a in axes:
        if shape[a] != 1:
            what = "the open batch axis" if shape[a] == B else f"axis {a} of size {shape[a]}"
            raise refuse(where, item, f"squeezes {what} of {shape_text_of(shape)}")
    return tuple(d for i, d in enumerate(shape) if i not in axes)


def _reshape(n: Node, shape: Shape, consts: dict[str, np.ndarray], where: str) -> Shape:
    """Reshape to a constant shape: 0 copies a dimension (unless allowzero), -1 takes the rest; an open batch
    dimension comes through whole (copied by 0, or as the -1 with all the other sizes kept)."""
    item = Item(n.op, n.path)
    if len(n.inputs) < 2 or n.inputs[1] not in consts:
        raise refuse(where, item, "target shape computed, not a constant")
    raw = [int(v) for v in np.asarray(consts[n.inputs[1]]).reshape(-1)]
    copy = not n.attrs.get("allowzero", 0)
    target = [shape[i] if copy and v == 0 and i < len(shape) else v for i, v in enumerate(raw)]
    if target.count(-1) > 1 or any(v < 1 and v not in (-1, B) for v in target):
        raise refuse(where, item, f"target shape {raw} of {shape_text_of(shape)}")
    size = math.prod(d for d in shape if d != B)
    others = math.prod(v for v in target if v not in (-1, B))
    if B in shape and B not in target:  # the -1 must be the batch
        if -1 not in target:
            why = "a fixed shape while the batch is open (it runs at one batch size)"
            raise refuse(where, item, f"reshape of {shape_text_of(shape)} to {raw}: {why}")
        if others != size:
            raise refuse(where, item, f"reshape of {shape_text_of(shape)} to {raw} mixes rows")
        return tuple(B if v == -1 else v for v in target)
    if (size % others if -1 in target else size != others) != 0:
        raise refuse(where, item, f"reshape of {shape_text_of(shape)} to {raw}")
    return tuple(size // others if v == -1 else v for v in target)
