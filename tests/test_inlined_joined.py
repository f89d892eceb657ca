"""ONNX local functions (onnxscript's @script functions) are inlined by onnx's own inliner before reading, the
oracle running the file as written; a TorchScript forward of two tensors it concatenates along the
features (scripted, traced, arguments swapped) is read as one input vector, its original fed the row's
columns split back; one joined along the batch is refused in one line. ~6 s."""

from __future__ import annotations

import sys

import numpy as np
import onnx
import pytest
import torch
from onnx import TensorProto, helper, numpy_helper

from seagen.cli import main
from seagen.export import prepare
from seagen.reference import numpy_ref
from seagen.reference.float_ref import quantize_features
from seagen.reference.oracle import box_points
from tests import table_models as T

MEAN, STD = np.array(T.MEAN), np.array(T.STD)


def _within(p, original, tmp_path) -> list[str]:
    """Export p; |integer - original (the test's runtime)| within bound + margin on box points; the notes."""
    ex = prepare(str(p), prefix="m", features=str(T.spec_file(tmp_path)))
    qm = ex.qmodel
    x = box_points(qm, 400, seed=2)
    got = numpy_ref.infer(qm, quantize_features(qm, x)) * 2.0**-qm.out_frac
    want = original((x - MEAN) / STD) * T.OUT_STD + T.OUT_MEAN
    assert np.max(np.abs(got - want)) <= qm.error_bound + ex.loaded.margin
    return ex.lines


def _helper_function_model():
    """A graph calling a local function 'dense_tanh' (MatMul, Add, Tanh) written with onnx.helper."""
    rng = np.random.default_rng(4)
    fn = helper.make_function(
        "local",
        "dense_tanh",
        ["x", "w", "b"],
        ["y"],
        [
            helper.make_node("MatMul", ["x", "w"], ["m"]),
            helper.make_node("Add", ["m", "b"], ["s"]),
            helper.make_node("Tanh", ["s"], ["y"]),
        ],
        [helper.make_opsetid("", 17)],
    )
    inits = {
        "W1": rng.uniform(-0.8, 0.8, (T.N_IN, T.HIDDEN)),
        "B1": rng.uniform(-0.3, 0.3, T.HIDDEN),
        "W2": rng.uniform(-0.8, 0.8, (T.HIDDEN, 1)),
    }
    graph = helper.make_graph(
        [
            helper.make_node("dense_tanh", ["x", "W1", "B1"], ["h"], domain="local"),
            helper.make_node("MatMul", ["h", "W2"], ["y"]),
        ],
        "g",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, ["N", T.N_IN])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, ["N", 1])],
        [numpy_helper.from_array(np.asarray(v, np.float32), k) for k, v in inits.items()],
    )
    ops = [helper.make_opsetid("", 17), helper.make_opsetid("local", 1)]
    return helper.make_model(graph, opset_imports=ops, functions=[fn])


def test_local_function_inlined(tmp_path):
    """A helper-built graph with a local function exports within bound of onnxruntime on the file; the
    note names the function."""
    model = _helper_function_model()
    onnx.checker.check_model(model)
    p = T.save_onnx(model, tmp_path / "fn.onnx")
    lines = _within(p, T.ort_original(p), tmp_path)
    assert any("dense_tanh" in ln and "onnx.inliner" in ln for ln in lines), lines


ONNXSCRIPT_SOURCE = """
import numpy as np
from onnx import numpy_helper
from onnxscript import FLOAT, script
from onnxscript import opset17 as op
from onnxscript.values import Opset

local = Opset("local", 1)
W1 = np.random.default_rng(5).uniform(-0.8, 0.8, (3, 8)).astype(np.float32)


@script(local, default_opset=op)
def dense_tanh(x, w, b):
    return op.Tanh(op.Add(op.MatMul(x, w), b))


@script()
def model(x: FLOAT["N", 3]) -> FLOAT["N", 1]:
    w1 = op.Constant(value=numpy_helper.from_array(W1, "w1"))
    b1 = op.Constant(value=numpy_helper.from_array(np.full(8, 0.1, np.float32), "b1"))
    w2 = op.Constant(value=numpy_helper.from_array(np.full((8, 1), 0.5, np.float32), "w2"))
    return op.MatMul(dense_tanh(x, w1, b1), w2)
"""


@pytest.mark.slow
def test_onnxscript_local_function_inlined(tmp_path, monkeypatch):
    """onnxscript's own output (a @script function called from the model) exports within bound (the
    onnxscript source sits in its own module: onnxscript reads its functions' source and annotations)."""
    import importlib.util

    pytest.importorskip("onnxscript")
    src = tmp_path / "osc_model.py"
    src.write_text(ONNXSCRIPT_SOURCE)
    spec = importlib.util.spec_from_file_location("osc_model", src)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "osc_model", mod)  # onnxscript reads the module's globals from it
    spec.loader.exec_module(mod)
    proto = mod.model.to_model_proto()
    assert len(proto.functions) == 1
    p = T.save_onnx(proto, tmp_path / "osc.onnx")
    _within(p, T.ort_original(p), tmp_path)


@pytest.mark.parametrize("form", ["scripted", "traced", "swapped"])
def test_torchscript_two_inputs_read_as_one_vector(form, tmp_path):
    """forward(a, b) = f(cat([a, b], 1)) saved as TorchScript: within bound of its own forward on the
    row's columns split (a: the first two, b: the last)."""
    m = T._init(T.TwoInputs(), 8)
    if form == "scripted":
        saved = torch.jit.script(m)
    elif form == "traced":
        saved = torch.jit.trace(m, (torch.zeros(3, 2), torch.zeros(3, 1)))
    else:
        m = T.TwoInputsSwapped(m).eval()
        saved = torch.jit.script(m)
    saved.save(str(tmp_path / "two.pt"))
    _within(tmp_path / "two.pt", T.torch_two_inputs(m, 2, swap=form == "swapped"), tmp_path)


def test_torchscript_rows_joined_refused(tmp_path, capsys):
    """Two inputs concatenated along the batch: exit 2, one line naming the file."""
    torch.jit.script(T._init(T.RowsJoined(), 9)).save(str(tmp_path / "rows.pt"))
    rc = main(["export", str(tmp_path / "rows.pt"), "--features", str(T.spec_file(tmp_path)), "--out",
               str(tmp_path / "o")])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "rows.pt" in err, err
    assert "2 inputs" in err and not (tmp_path / "o").exists()
