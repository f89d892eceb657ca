"""Reshapes to a shape computed from the batch size (`x.view(x.shape[0], -1)` through torch's ONNX
exporters: Shape -> Gather(0) -> Unsqueeze -> Concat with constants): read as the constant shape they are,
with ONNX's 0 ("copy this dimension") for the batch. Only when the size comes from the reshaped tensor itself,
or from the graph input when that is (batch, features): then the copied dimension is the same number."""

from __future__ import annotations

from typing import Any

import numpy as np

from seagen.frontends.graph import Node
from seagen.frontends.onnx_shapes import node_axes


def batch_reshapes(nodes: list[Node], consts: dict[str, Any], vi: Any) -> None:
    """Give each Reshape whose shape is [batch size of its own input (or of a (batch, features) graph
    input, `vi`), constants...] a constant shape [0, constants...] of its own (a fresh edge in consts)."""
    producer = {o: n for n in nodes for o in n.outputs if o}
    dims = vi.type.tensor_type.shape.dim
    open_batch = len(dims) == 2 and not (dims[0].HasField("dim_value") and dims[0].dim_value > 0)
    same_rows = {vi.name} if open_batch else set()
    for n in nodes:
        if n.op != "Reshape" or len(n.inputs) < 2 or n.inputs[1] in consts:
            continue
        rest = _batch_led(producer, consts, n.inputs[1], {n.inputs[0], *same_rows})
        if rest is not None:
            edge = f"{n.inputs[1]}#batch:{n.outputs[0]}"
            consts[edge] = np.concatenate([[0], rest]).astype(np.int64)
            n.inputs = [n.inputs[0], edge, *n.inputs[2:]]


def _batch_led(producer: dict[str, Node], consts: dict[str, Any], edge: str, sources: set[str]) -> Any:
    """The constants after the batch size when `edge` is Concat(axis 0)[Unsqueeze(Gather(Shape(t), 0)),
    constants...] with t one of `sources`; None otherwise."""
    cat = producer.get(edge)
    if cat is None or cat.op != "Concat" or cat.attrs.get("axis") != 0 or len(cat.inputs) < 2:
        return None
    if any(i not in consts for i in cat.inputs[1:]):
        return None
    unsq = producer.get(cat.inputs[0])
    if unsq is None or unsq.op != "Unsqueeze" or (len(unsq.inputs) > 1 and unsq.inputs[1] not in consts):
        return None
    if node_axes(unsq, consts, "") != [0]:
        return None
    gather = producer.get(unsq.inputs[0])
    if gather is None or gather.op != "Gather" or gather.attrs.get("axis", 0) != 0 or len(gather.inputs) < 2:
        return None
    idx = consts.get(gather.inputs[1])
    if idx is None or np.asarray(idx).shape != () or int(idx) != 0:
        return None
    shp = producer.get(gather.inputs[0])
    if shp is None or shp.op != "Shape" or shp.attrs.get("start", 0) != 0 or shp.inputs[0] not in sources:
        return None
    return np.concatenate([np.asarray(consts[i], dtype=np.int64).reshape(-1) for i in cat.inputs[1:]])
