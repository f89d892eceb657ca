"""Read a float ONNX MLP (Gemm/MatMul+Add with Relu, LeakyRelu, Clip, Tanh, Sigmoid) into float layers."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from seagen.errors import UserError
from seagen.ir import FloatLayer

_ACTS = {"Relu": "relu", "LeakyRelu": "leaky_relu", "Clip": "hardtanh", "Tanh": "tanh", "Sigmoid": "sigmoid"}


def _read(path: Path) -> tuple[object, dict[str, np.ndarray]]:
    """The ONNX model and its constant tensors (initializers and Constant nodes) as float arrays."""
    import onnx
    from onnx import numpy_helper

    try:
        model = onnx.load(str(path))
    except Exception as e:  # onnx raises several types for unreadable files
        raise UserError(f"{path}: not a readable ONNX file: {e}") from None
    init = {t.name: numpy_helper.to_array(t).astype(float) for t in model.graph.initializer}
    for n in model.graph.node:
        if n.op_type == "Constant":
            init[n.output[0]] = numpy_helper.to_array(n.attribute[0].t).astype(float)
    return model, init


def _apply(layers: list[FloatLayer], node, attrs: dict, init: dict, path: Path) -> None:
    """Append or complete a layer for one graph node; anything else is an unsupported node."""
    op = node.op_type
    if op == "Gemm":
        w = init[node.input[1]]
        w = w if attrs.get("transB", 0) else w.T
        b = init[node.input[2]] if len(node.input) > 2 else np.zeros(w.shape[0])
        layers.append(FloatLayer(w * attrs.get("alpha", 1.0), b * attrs.get("beta", 1.0)))
    elif op == "MatMul" and node.input[1] in init:
        w = init[node.input[1]].T
        layers.append(FloatLayer(w, np.zeros(w.shape[0])))
    elif op == "Add" and layers and any(i in init for i in node.input):
        bias = init[next(i for i in node.input if i in init)].reshape(-1)
        layers[-1] = FloatLayer(layers[-1].weight, layers[-1].bias + bias)
    elif op in _ACTS and layers:
        layers[-1] = _act(layers[-1], op, node, attrs, init)
    else:
        raise UserError(f"{path}: unsupported ONNX node {op} ('{node.name}')")


def onnx_layers(path: Path) -> list[FloatLayer]:
    """Walk the graph in order; every node must be one of the supported layer types."""
    import onnx

    model, init = _read(path)
    layers: list[FloatLayer] = []
    for node in model.graph.node:  # type: ignore[attr-defined]
        if node.op_type != "Constant":
            attrs = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
            _apply(layers, node, attrs, init, path)
    if not layers:
        raise UserError(f"{path}: no Gemm or MatMul layer found")
    for i, lay in enumerate(layers):
        if not (np.all(np.isfinite(lay.weight)) and np.all(np.isfinite(lay.bias))):
            raise UserError(f"{path}: layer {i} has NaN or Inf weights")
    return layers


def _act(layer: FloatLayer, op: str, node: object, attrs: dict, init: dict) -> FloatLayer:
    lo, hi = -1.0, 1.0
    if op == "Clip":
        ins = list(node.input)  # type: ignore[attr-defined]
        lo = float(init[ins[1]]) if len(ins) > 1 and ins[1] else float(attrs.get("min", -np.inf))
        hi = float(init[ins[2]]) if len(ins) > 2 and ins[2] else float(attrs.get("max", np.inf))
        if op == "Clip" and lo == 0 and hi == np.inf:
            return FloatLayer(layer.weight, layer.bias, "relu")
    return FloatLayer(
        layer.weight, layer.bias, _ACTS[op], alpha=float(attrs.get("alpha", 0.01)), lo=lo, hi=hi
    )
