"""ONNX's own backend node tests (onnx.backend.test.case.node) for the ops seagen claims, as seagen models.

Each single-node test case becomes a graph seagen can read: the test's first input is the graph input, laid
out as (rows, features) by a pure relayout of the test's own data (elementwise ops: (-1, last dim);
BatchNormalization: channels last; Flatten(axis=1) and 2-D Reshape: (N, -1)); its other inputs become
initializers holding the test's values; an identity MatMul goes before an activation (seagen reads an
activation after a dense layer) and a MatMul by a fixed random column after the node (seagen exports one
output). ONNX's expected outputs, relaid out the same way and multiplied by that column, are the oracle.
The batch dimension is either symbolic ("N") or fixed to the test's row count.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

CLAIMED = (
    "Gemm", "MatMul", "Add", "Sub", "Mul", "Div", "Relu", "LeakyRelu", "Clip", "Tanh", "Sigmoid",
    "BatchNormalization", "Dropout", "Identity", "Cast", "Flatten", "Reshape",
)  # fmt: skip
ACTIVATIONS = ("Relu", "LeakyRelu", "Clip", "Tanh", "Sigmoid")
ELEMENTWISE = (*ACTIVATIONS, "Add", "Sub", "Mul", "Div", "Dropout", "Identity", "Cast")
FLOATS = (TensorProto.FLOAT, TensorProto.DOUBLE, TensorProto.FLOAT16)


@dataclass
class NodeCase:
    """One backend test case as a seagen model: the graph, the test's rows and ONNX's expected column."""

    name: str  # e.g. "test_relu[fixed]"
    op: str
    model: Any  # onnx.ModelProto
    x: np.ndarray  # (rows, features) float64: the test's input, relaid out
    want: np.ndarray  # (rows,) float64: ONNX's expected output, relaid out, times the output column
    spec: dict[str, Any]  # the --features dict: identity normalisation, the rows' range


# the modules of onnx.backend.test.case.node whose generators write the claimed ops' cases (importing one
# runs its generators; collect_testcases() would run every op's generators, ~5 s of CPU)
MODULES = (
    "gemm", "matmul", "add", "sub", "mul", "div", "relu", "leakyrelu", "clip", "tanh", "sigmoid",
    "batch_normalization", "dropout", "identity", "cast", "castlike", "flatten", "reshape",
)  # fmt: skip


@cache
def _testcases() -> tuple[Any, ...]:
    """The installed onnx package's node test cases for the claimed ops (generated once)."""
    import importlib

    import onnx.backend.test.case.node as node_cases

    for m in MODULES:
        importlib.import_module(f"onnx.backend.test.case.node.{m}")
    return tuple(node_cases._NodeTestCases)


def _layout(op: str, node: Any, a: np.ndarray) -> np.ndarray | None:
    """The relayout of a test tensor to (rows, features) under which `op` computes the same values; None
    when the op has no such form for this case."""
    attrs = {x.name: helper.get_attribute_value(x) for x in node.attribute}
    if op in ELEMENTWISE and a.ndim >= 1:
        return a.reshape(-1, a.shape[-1])
    if op == "BatchNormalization" and a.ndim >= 2:
        return np.moveaxis(a, 1, -1).reshape(-1, a.shape[1])
    if op == "Flatten" and attrs.get("axis", 1) == 1 and a.ndim >= 2:
        return a.reshape(len(a), -1)
    if op in ("Gemm", "MatMul", "Reshape") and a.ndim == 2:
        return a
    if op == "Reshape" and a.ndim > 2:
        return a.reshape(len(a), -1)
    return None


def _const(op: str, value: np.ndarray, x_shape: tuple, x2_shape: tuple) -> np.ndarray:
    """A second input as an initializer: relaid out with the first when it has its full shape."""
    if op in ELEMENTWISE and value.shape == x_shape and value.ndim >= 1:
        return value.reshape(x2_shape)
    return value


def _array(a: Any) -> np.ndarray:
    """A test's value as numpy (some cases store TensorProto)."""
    return numpy_helper.to_array(a) if isinstance(a, onnx.TensorProto) else np.asarray(a)


def build(tc: Any, batch: str) -> NodeCase | None:
    """One test case in one batch form ("symbolic" or "fixed"); None when it has no seagen form (not a
    single claimed op, a non-float input or output, a layout the op does not allow)."""
    g = tc.model.graph
    if len(g.node) != 1 or g.node[0].op_type not in CLAIMED or not tc.data_sets:
        return None
    node, op = g.node[0], g.node[0].op_type
    inputs, outputs = ([_array(a) for a in side] for side in tc.data_sets[0])
    in_t, out_t = g.input[0].type.tensor_type.elem_type, g.output[0].type.tensor_type.elem_type
    if in_t not in FLOATS or out_t not in FLOATS:
        return None
    x0, y0 = np.asarray(inputs[0]), np.asarray(outputs[0])
    if op == "Reshape" and (y0.ndim != 2 or len(y0) != len(x0)):
        return None
    x, y = _layout(op, node, x0), _layout(op, node, y0)
    if x is None or y is None or len(x) != len(y) or x.shape[1] == 0:
        return None
    k, m = x.shape[1], y.shape[1]
    col = np.random.default_rng(0).uniform(0.5, 1.0, (m, 1)) * np.where(np.arange(m) % 2, -1.0, 1.0)[:, None]
    col_t = col.astype(helper.tensor_dtype_to_np_dtype(out_t))
    inits = [
        numpy_helper.from_array(_const(op, np.asarray(v), x0.shape, x.shape), vi.name)
        for vi, v in zip(g.input[1:], inputs[1:], strict=False)
    ]
    inits.append(numpy_helper.from_array(col_t, "seagen_col"))
    node2 = onnx.NodeProto()
    node2.CopyFrom(node)
    first = node.input[0]
    nodes = [node2]
    if op in ACTIVATIONS:  # an identity dense layer before the activation
        eye = np.eye(k, dtype=helper.tensor_dtype_to_np_dtype(in_t))
        inits.append(numpy_helper.from_array(eye, "seagen_eye"))
        nodes.insert(0, helper.make_node("MatMul", ["seagen_x", "seagen_eye"], [first]))
        graph_in = "seagen_x"
    else:
        graph_in = first
    nodes.append(helper.make_node("MatMul", [node.output[0], "seagen_col"], ["seagen_y"]))
    rows: int | str = len(x) if batch == "fixed" else "N"  # the test's row count, before dropping any
    graph = helper.make_graph(
        nodes,
        tc.name,
        [helper.make_tensor_value_info(graph_in, in_t, [rows, k])],
        [helper.make_tensor_value_info("seagen_y", out_t, [rows, 1])],
        inits,
    )
    model = helper.make_model(graph, opset_imports=tc.model.opset_import, ir_version=tc.model.ir_version)
    finite = np.all(np.isfinite(x), axis=1) & np.all(np.isfinite(np.asarray(y, dtype=float)), axis=1)
    if not finite.any():
        return None
    x, y = x[finite], y[finite]  # the rows a calibrated box can hold (Cast's cases carry NaN and Inf)
    lo, hi = x.min(axis=0).astype(float), x.max(axis=0).astype(float)
    pad = np.where(hi > lo, 0.0, np.maximum(np.abs(lo), 1.0))
    spec = {
        "features": {"inputs": [f"c{i}" for i in range(k)], "mean": [0.0] * k, "std": [1.0] * k},
        "input_range": [[float(a - p), float(b + p)] for a, b, p in zip(lo, hi, pad, strict=True)],
        "output_name": "y",
    }
    want = (np.asarray(y, dtype=float) @ col_t.astype(float))[:, 0]
    return NodeCase(f"{tc.name}[{batch}]", op, model, np.asarray(x, dtype=float), want, spec)


def all_cases() -> list[NodeCase]:
    """Every claimed-op test case that has a seagen form, in both batch forms."""
    out = []
    for tc in _testcases():
        for batch in ("symbolic", "fixed"):
            c = build(tc, batch)
            if c is not None:
                out.append(c)
    return out


def case_names() -> list[str]:
    """The names of all_cases() (for test parametrisation)."""
    return [c.name for c in all_cases()]
