"""Converters' idioms for the model table, built with onnx.helper as the converters write them: jax2onnx's
ReLU as Max(x, 0) and ReLU6 as Max then Min; batch bookkeeping (Unsqueeze, Squeeze, Reshape, Flatten) at
the graph's input and output; onnxconverter-common's float16 graph with keep_io_types=True (a Cast to float16
after the input, float16 weights, a Cast back to float before the output); and the forms of each that seagen
refuses."""

from __future__ import annotations

import numpy as np
from onnx import TensorProto, helper, numpy_helper

from tests.table_models import HIDDEN, N_IN, onnx_model, weights

# kind: what must happen (a refusal's message)
EXPORTED = (
    "jax2onnx relu as Max(x, 0)", "jax2onnx relu6 as Max then Min", "Min then Max (a clip)",
    "1-D input, Unsqueeze in, Squeeze out", "Squeeze(axis 1) output", "Flatten in, Reshape(-1) out",
    "3-D input (N, 1, 3) reshaped", "float16 body between Casts (keep_io_types)",
)  # fmt: skip
REFUSED = {
    "Max by a vector": "constant of shape (8,)",
    "Squeeze of the batch axis": "squeezes the open batch axis",
    "Reshape mixing rows": "mixes rows",
    "Reshape to a fixed batch": "a fixed shape while the batch is open",
    "Cast to int32": "(Cast): a cast to INT32",
}


def _mlp(first: str, mid: list, seed: int, scale: float = 1.0, dtype=np.float32) -> tuple[list, dict]:
    """MatMul + Add, the given middle nodes (from 'h' to 'a'), MatMul + Add to 'y' (jax2onnx's dense
    layers: dot_general then add); `first` is the edge the first MatMul reads."""
    w = weights(seed)
    nodes = [
        helper.make_node("MatMul", [first, "W1T"], ["m1"]),
        helper.make_node("Add", ["m1", "B1"], ["h"]),
        *mid,
        helper.make_node("MatMul", ["a", "W2T"], ["m2"]),
        helper.make_node("Add", ["m2", "B2"], ["y"]),
    ]
    inits = {"W1T": w["W1"].T * scale, "B1": w["B1"], "W2T": w["W2"].T, "B2": w["B2"]}
    return nodes, {k: np.asarray(v, dtype) for k, v in inits.items()}


def _io(model, in_shape: list, out_shape: list, ints: dict | None = None, elem: int = TensorProto.FLOAT):
    """The model with its input 'x' and output 'y' declared with these shapes and type, and int64
    initializers (axes, shapes) added."""
    model.graph.input[0].CopyFrom(helper.make_tensor_value_info("x", elem, in_shape))
    model.graph.output[0].CopyFrom(helper.make_tensor_value_info("y", elem, out_shape))
    for name, v in (ints or {}).items():
        model.graph.initializer.append(numpy_helper.from_array(np.asarray(v, np.int64), name))
    return model


def _clips(kind: str, seed: int):
    """Max/Min by constant numbers (scalar, as jax2onnx writes them) after the first dense layer."""
    if kind == "jax2onnx relu as Max(x, 0)":
        nodes, inits = _mlp("x", [helper.make_node("Max", ["h", "ZERO"], ["a"])], seed)
        return onnx_model(nodes, {**inits, "ZERO": np.float32(0.0)})
    if kind == "jax2onnx relu6 as Max then Min":  # weights x4: both bounds are reached on the box
        mid = [helper.make_node("Max", ["h", "ZERO"], ["r"]), helper.make_node("Min", ["r", "SIX"], ["a"])]
        nodes, inits = _mlp("x", mid, seed, scale=4.0)
        return onnx_model(nodes, {**inits, "ZERO": np.float32(0.0), "SIX": np.float32(6.0)})
    if kind == "Min then Max (a clip)":
        mid = [helper.make_node("Min", ["h", "HI"], ["r"]), helper.make_node("Max", ["r", "LO"], ["a"])]
        nodes, inits = _mlp("x", mid, seed)
        return onnx_model(nodes, {**inits, "HI": np.float32([0.4]), "LO": np.float32([[-0.3]])})
    nodes, inits = _mlp("x", [helper.make_node("Max", ["h", "C"], ["a"])], seed)  # Max by a vector
    return onnx_model(nodes, {**inits, "C": np.full(HIDDEN, 0.1, np.float32)})


def _shapes(kind: str, seed: int):
    """Shape-only nodes at the graph's ends; axes as inputs (opset 13+) or attributes (opset 11)."""
    relu = [helper.make_node("Relu", ["h"], ["a"])]
    if kind == "1-D input, Unsqueeze in, Squeeze out":  # one sample (features,) in, a scalar out
        nodes, inits = _mlp("x2", relu, seed)
        nodes.insert(0, helper.make_node("Unsqueeze", ["x", "AX0"], ["x2"]))
        nodes[-1].output[0] = "y2"
        nodes.append(helper.make_node("Squeeze", ["y2"], ["y"]))
        return _io(onnx_model(nodes, inits), [N_IN], [], {"AX0": [0]})
    if kind in ("Squeeze(axis 1) output", "Squeeze of the batch axis"):
        nodes, inits = _mlp("x", relu, seed)
        nodes[-1].output[0] = "y2"
        axis = 1 if kind.startswith("Squeeze(") else 0
        nodes.append(helper.make_node("Squeeze", ["y2"], ["y"], axes=[axis]))
        return _io(onnx_model(nodes, inits, opset=11), ["N", N_IN], ["N"])
    if kind == "Flatten in, Reshape(-1) out":
        nodes, inits = _mlp("x2", relu, seed)
        nodes.insert(0, helper.make_node("Flatten", ["x"], ["x2"], axis=1))
        nodes[-1].output[0] = "y2"
        nodes.append(helper.make_node("Reshape", ["y2", "FLAT"], ["y"]))
        return _io(onnx_model(nodes, inits), ["N", N_IN], ["N"], {"FLAT": [-1]})
    target = {"3-D input (N, 1, 3) reshaped": [-1, N_IN], "Reshape mixing rows": [1, -1]}
    nodes, inits = _mlp("x2", relu, seed)
    shape = target.get(kind, [4, N_IN])  # else: to a fixed batch of 4
    nodes.insert(0, helper.make_node("Reshape", ["x", "TO"], ["x2"]))
    return _io(onnx_model(nodes, inits), ["N", 1, N_IN], ["N", 1], {"TO": shape})


def _float16(kind: str, seed: int):
    """onnxconverter-common's float16 graph with keep_io_types=True: float32 in and out, a Cast to float16
    after the input, float16 weights, a Cast to float before the output (its node names); or a Cast to int."""
    to = TensorProto.FLOAT16 if kind.startswith("float16") else TensorProto.INT32
    dtype = np.float16 if to == TensorProto.FLOAT16 else np.float32
    nodes, inits = _mlp("graph_input_cast0", [helper.make_node("Tanh", ["h"], ["a"])], seed, dtype=dtype)
    nodes[-1].output[0] = "graph_output_cast0"
    nodes.insert(0, helper.make_node("Cast", ["x"], ["graph_input_cast0"], "graph_input_cast_0", to=to))
    nodes.append(
        helper.make_node("Cast", ["graph_output_cast0"], ["y"], "graph_output_cast_0", to=TensorProto.FLOAT)
    )
    return _io(onnx_model(nodes, inits, dtype=dtype), ["N", N_IN], ["N", 1])


def idiom_case(kind: str, seed: int):
    """The graph of one idiom (a kind of EXPORTED or REFUSED)."""
    if "Max" in kind or "Min" in kind:
        return _clips(kind, seed)
    if "float16" in kind or "Cast" in kind:
        return _float16(kind, seed)
    return _shapes(kind, seed)


def float16_weights_exactly(model) -> bool:
    """Every initializer of the float16 body is float16 (what the reader converts exactly to float)."""
    arrays = [numpy_helper.to_array(t) for t in model.graph.initializer]
    return all(a.dtype == np.float16 for a in arrays)
