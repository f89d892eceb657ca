"""Readers read what ONNX and torch define or refuse at read time, in one line naming the file: symbolic
dimensions by name, unrepresentable ranges, errors of the original's own runtime, fixed batch sizes, the
margin a float16 original is allowed (recorded in the manifest). ~5 s."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from onnx import TensorProto, helper
from torch import nn

from seagen.cli import main
from seagen.errors import UserError
from seagen.frontends import batched, read_onnx
from seagen.frontends.margin import forward_margin
from seagen.ir import FloatLayer
from tests import table_models as T


def _export(args: list[str], out, capsys) -> tuple[int, str]:
    rc = main(["export", *args, "--out", str(out), "--prefix", "m"])
    return rc, capsys.readouterr().err


def test_symbolic_dimensions_printed_by_name(tmp_path, capsys):
    """An input of shape (N, F, 2) is refused naming N and F, not printing them as 0."""
    m = T.onnx_model([helper.make_node("Relu", ["x"], ["y"])], {})
    m.graph.input[0].CopyFrom(helper.make_tensor_value_info("x", TensorProto.FLOAT, ["N", "F", 2]))
    p = T.save_onnx(m, tmp_path / "sym.onnx")
    rc, err = _export([str(p), "--features", str(T.spec_file(tmp_path))], tmp_path / "o", capsys)
    assert rc == 2 and "has shape [N, F, 2]" in err and str(p) in err and len(err.strip().splitlines()) == 1


def test_unrepresentable_range_names_the_file(tmp_path, capsys):
    """An input range int16 cannot hold is refused naming the model file and the input."""
    spec = json.loads(T.spec_file(tmp_path).read_text())
    spec["input_range"][0] = [0.0, 1e12]
    spec["std"][0] = 1e11
    (tmp_path / "wide.json").write_text(json.dumps(spec))
    p = T.save_onnx(T.gemm_graph("transB0", 1), tmp_path / "g.onnx")
    rc, err = _export([str(p), "--features", str(tmp_path / "wide.json")], tmp_path / "o", capsys)
    assert rc == 2 and err.startswith(f"seagen: error: {p}: input 'pot'") and "cannot be represented" in err


def test_onnxruntime_error_is_one_line(tmp_path):
    """An error onnxruntime raises running the original is a UserError naming the file, not a traceback."""
    p = T.save_onnx(T.gemm_graph("transB0", 1), tmp_path / "g.onnx")
    net = read_onnx(p)
    with pytest.raises(UserError, match=f"^{p}: onnxruntime failed running the original graph: ") as e:
        net.run(np.zeros((5, 4)))  # four columns for a three-input graph
    assert "\n" not in str(e.value)


class _SmallBatches(nn.Module):
    """A forward that raises for batches above 64 (its runtime's own error)."""

    def __init__(self) -> None:
        super().__init__()
        self.fc, self.out = nn.Linear(T.N_IN, T.HIDDEN), nn.Linear(T.HIDDEN, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.shape[0] > 64:
            raise ValueError("batch above 64\nsecond line")
        return self.out(torch.relu(self.fc(x)))


def test_torch_forward_error_is_one_line(tmp_path, capsys):
    """A TorchScript forward that raises on the oracle's batch: exit 2, one line naming the file."""
    p = tmp_path / "small.pt"
    T._quiet(torch.jit.script(T._init(_SmallBatches(), 3)).save, str(p))
    rc, err = _export([str(p), "--features", str(T.spec_file(tmp_path))], tmp_path / "o", capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert f"{p}: the model's own forward failed" in err and "batch above 64" in err


def test_batched_feeds_the_declared_batch():
    """A fixed-batch runner sees only batches of its size; the padding is dropped from the result."""
    seen = []

    def run(x):
        seen.append(len(x))
        return x[:, :1] * 2.0

    x = np.arange(14.0).reshape(7, 2)
    y = batched(run, 3)(x)
    assert set(seen) == {3} and np.array_equal(y[:, 0], x[:, 0] * 2.0)


def test_fixed_batch_onnx_runs_in_its_batch(tmp_path):
    """A graph whose input, output and a Reshape fix the batch at 1 runs on 2009 rows through its runner."""
    p = T.save_onnx(T.graph_case("fixed_batch_1", 5), tmp_path / "b1.onnx")
    net = read_onnx(p)
    x = np.random.default_rng(0).normal(size=(50, T.N_IN))
    assert np.allclose(net.run(x)[:, 0], T.ort_original(p)(x))


def test_margin_scales_with_the_float_type():
    """The same layers get a margin 2^13 larger in float16 than in float32 (the unit roundoffs' ratio) at
    first order, and bfloat16 a larger one still."""
    lay = [
        FloatLayer(np.full((4, 3), 0.5), np.zeros(4), "tanh"),
        FloatLayer(np.full((1, 4), 0.5), np.zeros(1)),
    ]
    xmax = np.ones(3)
    m32, m16, mb = (forward_margin(lay, xmax, d) for d in ("float32", "float16", "bfloat16"))
    assert 2**13 * 0.99 < m16 / m32 < 2**13 * 1.05 and mb > m16


def test_float16_manifest_records_dtype_and_margin(tmp_path, capsys):
    """A float16 module exports with the margin of its float type; the manifest records type and margin."""
    m = T.seq(nn.ReLU(), seed=4).half()
    torch.save(m, tmp_path / "half.pt")
    rc, err = _export(
        [str(tmp_path / "half.pt"), "--features", str(T.spec_file(tmp_path))], tmp_path / "o", capsys
    )
    assert rc == 0, err
    man = json.loads((tmp_path / "o" / "m.seagen.json").read_text())
    orig = man["resolved"]["original"]
    assert orig["dtype"] == "float16" and orig["runtime"] == "torch forward (float16)" and orig["margin"] > 0
    assert man["resolved"]["error_bound"] < orig["margin"]  # the proven bound is the integer path's own


def test_training_mode_sequential_says_so(tmp_path, capsys):
    """An nn.Sequential with Dropout saved in training mode exports its eval behaviour and says so."""
    m = T.seq(nn.ReLU(), nn.Dropout(0.5), seed=5).train()
    torch.save(m, tmp_path / "train.pt")
    rc = main(["export", str(tmp_path / "train.pt"), "--features", str(T.spec_file(tmp_path)), "--out",
               str(tmp_path / "o"), "--prefix", "m"])  # fmt: skip
    out = capsys.readouterr().out
    assert rc == 0 and "train.pt was saved in training mode; exported its inference (eval-mode)" in out


def test_random_original_refused():
    """An original whose outputs differ between two runs on the same inputs is refused before any check."""
    from seagen.frontends import Network
    from seagen.frontends.load import _deterministic

    rng = np.random.default_rng(0)
    net = Network([], 3, lambda x: x[:, :1] + rng.normal(size=(len(x), 1)), "test")
    with pytest.raises(UserError, match="different outputs for the same inputs on two runs"):
        _deterministic(net, np.ones(3), "m.onnx")
    _deterministic(Network([], 3, lambda x: x[:, :1], "test"), np.ones(3), "m.onnx")
