"""Converters' idioms read exactly: clips in a row compose to the one clip they are, the batch bookkeeping at
a graph's ends is followed on the shapes (or refused in one line), a float16 body's weights are its float16
values exactly and its margin is float16's, and the original runs on inputs laid out as its graph declares
them. ~3 s."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from onnx import TensorProto, helper

from seagen.errors import UserError
from seagen.frontends import read_onnx
from seagen.frontends.chain import Act, clip_act, merge_clips
from seagen.frontends.graph import Node
from seagen.frontends.onnx_shapes import B, after
from tests import table_models as T
from tests import table_onnx_idioms as I

BOUNDS = [-np.inf, -2.0, -0.5, 0.0, 0.5, 3.0, np.inf]


def _clip(x: np.ndarray, it: Act) -> np.ndarray:
    """An IR clip activation applied as the IR defines it."""
    lo, hi = (0.0, np.inf) if it.kind == "relu" else (it.lo, it.hi)
    return np.minimum(np.maximum(x, lo), hi)


def test_clips_in_a_row_compose_to_one():
    """For every pair of clips (bounds including +-inf, inverted ones, ReLU): the merged clip equals the two
    applied in turn at every point of a fine grid."""
    x = np.linspace(-6.0, 6.0, 2401)
    for a, b, c, d in itertools.product(BOUNDS, repeat=4):
        first, second = clip_act("Max", "p", a, b), clip_act("Min", "q", c, d)
        (merged,) = merge_clips([first, second])
        assert isinstance(merged, Act)
        assert np.array_equal(_clip(x, merged), _clip(_clip(x, first), second)), (a, b, c, d)


def _node(op: str, inputs: tuple[str, ...] = ("t",), **attrs) -> Node:
    return Node(op, f"n_{op}", ["t", *inputs[1:]], ["u"], attrs)


SHAPES = [  # (shape in, node, constants, shape out or the refusal's text)
    ((3,), _node("Unsqueeze", ("t", "A")), {"A": [0]}, (1, 3)),
    ((B, 3), _node("Unsqueeze", axes=[-1]), {}, (B, 3, 1)),
    ((B, 1, 3), _node("Squeeze", axes=[1]), {}, (B, 3)),
    ((1, 1), _node("Squeeze"), {}, ()),
    ((B, 1), _node("Squeeze", axes=[0]), {}, "squeezes the open batch axis"),
    ((B, 1), _node("Squeeze"), {}, "Squeeze without axes"),
    ((B, 3), _node("Squeeze", axes=[1]), {}, "squeezes axis 1 of size 3"),
    ((B, 1, 3), _node("Flatten", axis=1), {}, (B, 3)),
    ((B, 1, 3), _node("Flatten", axis=-1), {}, (B, 3)),
    ((B, 3), _node("Flatten", axis=0), {}, "merges the batch axis with features"),
    ((B, 1, 3), _node("Reshape", ("t", "S")), {"S": [0, 3]}, (B, 3)),
    ((B, 1, 3), _node("Reshape", ("t", "S")), {"S": [-1, 3]}, (B, 3)),
    ((B, 1), _node("Reshape", ("t", "S")), {"S": [-1]}, (B,)),
    ((6,), _node("Reshape", ("t", "S")), {"S": [2, -1]}, (2, 3)),
    ((B, 3), _node("Reshape", ("t", "S")), {"S": [1, -1]}, "mixes rows"),
    ((B, 3), _node("Reshape", ("t", "S")), {"S": [3, -1]}, "moves the batch axis"),
    ((B, 3), _node("Reshape", ("t", "S")), {"S": [0, -1, 3]}, (B, 1, 3)),
    ((B, 3), _node("Reshape", ("t", "S")), {"S": [1, 0, 3]}, "a fixed shape"),  # 0 copies the 3
    ((B, 3), _node("Reshape", ("t", "S"), allowzero=1), {"S": [0, 3]}, "target shape"),
    ((B, 3), _node("Reshape", ("t", "S")), {"S": [5, 3]}, "a fixed shape while the batch is open"),
    ((B, 1), _node("Reshape", ("t", "S")), {"S": [1, -1]}, (1, B)),  # rows still in order
]


@pytest.mark.parametrize("case", range(len(SHAPES)))
def test_shape_only_nodes_followed_or_refused(case):
    """Each shape-only node gives the shape ONNX defines, or is refused in one line when it would mix rows,
    squeeze, merge or fix the open batch dimension."""
    shape, node, consts, want = SHAPES[case]
    arrays = {k: np.asarray(v, np.int64) for k, v in consts.items()}
    if isinstance(want, tuple):
        assert after(node, shape, arrays, "g.onnx") == want
    else:
        with pytest.raises(UserError, match=want) as e:
            after(node, shape, arrays, "g.onnx")
        assert "\n" not in str(e.value) and str(e.value).startswith("g.onnx: n_")


def test_float16_body_read_exactly_with_the_float16_margin(tmp_path):
    """The keep_io_types graph: weights are the float16 values converted exactly, the margin is float16's,
    and the original runs as onnxruntime runs the file."""
    model = I.idiom_case("float16 body between Casts (keep_io_types)", 3)
    assert I.float16_weights_exactly(model)
    p = T.save_onnx(model, tmp_path / "f16.onnx")
    net = read_onnx(p)
    w16 = {t.name: t for t in model.graph.initializer}
    from onnx import numpy_helper

    want = numpy_helper.to_array(w16["W1T"]).astype(np.float64).T
    assert np.array_equal(net.layers[0].weight, want) and net.dtype == "float16"
    x = np.random.default_rng(0).normal(size=(40, T.N_IN))
    assert np.array_equal(net.run(x)[:, 0], T.ort_original(p)(x))


def test_a_cast_to_float16_inside_a_float32_graph_sets_the_margin(tmp_path):
    """A float32 graph with a Cast to float16 after its first layer: read as the identity, margin of
    float16 (the rounding the cast adds)."""
    w = T.weights(1)
    nodes = [
        helper.make_node("Gemm", ["x", "W1", "B1"], ["h"], transB=1),
        helper.make_node("Cast", ["h"], ["h16"], to=TensorProto.FLOAT16),
        helper.make_node("Cast", ["h16"], ["h32"], to=TensorProto.FLOAT),
        helper.make_node("Relu", ["h32"], ["a"]),
        helper.make_node("Gemm", ["a", "W2", "B2"], ["y"], transB=1),
    ]
    p = T.save_onnx(T.onnx_model(nodes, w), tmp_path / "cast.onnx")
    assert read_onnx(p).dtype == "float16"


def test_one_sample_input_runs_one_row_per_run(tmp_path):
    """A (features,) input: the original takes one row per run, in order, for any number of rows."""
    p = T.save_onnx(I.idiom_case("1-D input, Unsqueeze in, Squeeze out", 2), tmp_path / "one.onnx")
    net = read_onnx(p)
    x = np.random.default_rng(1).normal(size=(7, T.N_IN))
    want = [net.layers[1].weight @ np.maximum(net.layers[0].weight @ r + net.layers[0].bias, 0) for r in x]
    got = net.run(x)[:, 0]
    assert got.shape == (7,)
    assert np.allclose(got, np.array(want)[:, 0] + net.layers[1].bias[0], atol=1e-5)
