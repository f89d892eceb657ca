"""Idioms of torch files (issue 36), each exported and checked against the module's own forward within the
proven bound: a TorchScript module holding a torch.device (what LightningModule.to_torchscript() writes)
read without --allow-pickle, torch.tensor([...]) constants in a scripted forward, and view(x.shape[0], -1)
in a .pt2 exported with a dynamic batch, two inputs concatenated into one vector. ~10 s."""

from __future__ import annotations

import re
import struct
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch
from onnx import TensorProto, helper

from seagen.cli import main
from seagen.export import prepare
from seagen.filekind import pickle_globals
from seagen.reference import numpy_ref
from seagen.reference.float_ref import quantize_features
from seagen.reference.oracle import box_points
from tests import table_models as T
from tests.table_models import Row


def _rows(d: Path, spec: list[str]) -> dict[str, Row]:
    """The idiom rows, each file written by torch itself."""
    rows: dict[str, Row] = {}
    m = T._init(T.DeviceAttr(), 100)
    T._quiet(torch.jit.script(m).save, str(d / "device.pt"))
    rows["TorchScript with a torch.device attribute"] = Row(
        [str(d / "device.pt"), *spec], "export", original=T.torch_original(m)
    )
    m = T._init(T.TensorConst(), 101)
    T._quiet(torch.jit.script(m).save, str(d / "tensor_const.pt"))
    rows["TorchScript torch.tensor constants"] = Row(
        [str(d / "tensor_const.pt"), *spec], "export", original=T.torch_original(m)
    )
    T._quiet(torch.jit.script(T._init(T.TensorConstMixed(), 105)).save, str(d / "tensor_mixed.pt"))
    rows["TorchScript torch.tensor of mixed ints and floats (refused)"] = Row(
        [str(d / "tensor_mixed.pt"), *spec], "refuse", 2, "cannot read the TorchScript graph"
    )
    m = T._init(T.ViewBatch(), 102)
    ep = T._quiet(torch.export.export, m, T.example(), dynamic_shapes=({0: torch.export.Dim("batch")},))
    torch.export.save(ep, d / "view_batch.pt2")
    rows[".pt2 dynamic batch view(x.shape[0], -1)"] = Row(
        [str(d / "view_batch.pt2"), *spec], "export", original=T.torch_original(m)
    )
    return rows | _view_rows(d, spec) | _two_input_rows(d, spec)


def _view_rows(d: Path, spec: list[str]) -> dict[str, Row]:
    """view(x.shape[0], -1) scripted, traced and through the legacy ONNX exporter (Shape, Gather, Unsqueeze,
    Concat into the Reshape's shape), and a reshape to (batch // 2, -1), which joins rows (refused)."""
    rows: dict[str, Row] = {}
    m = T._init(T.ViewBatch(), 106)
    T._quiet(torch.jit.script(m).save, str(d / "view_script.pt"))
    rows["TorchScript scripted view(x.shape[0], -1)"] = Row(
        [str(d / "view_script.pt"), *spec], "export", original=T.torch_original(m)
    )
    T._quiet(torch.jit.trace, m, T.example()).save(str(d / "view_trace.pt"))
    rows["TorchScript traced view(x.shape[0], -1)"] = Row(
        [str(d / "view_trace.pt"), *spec], "export", original=T.torch_original(m)
    )
    for name, mod in (("view", m), ("half_rows", T._init(T.HalfRows(), 107))):
        p = d / f"{name}_legacy.onnx"
        axes = {"x": {0: "N"}}
        T._quiet(
            torch.onnx.export, mod, T.example(), str(p), dynamo=False, input_names=["x"], dynamic_axes=axes
        )
        if name == "view":
            rows["onnx legacy view(x.shape[0], -1)"] = Row(
                [str(p), *spec], "export", original=T.ort_original(p)
            )
        else:
            rows["onnx legacy reshape(x.shape[0] // 2, -1) (refused)"] = Row(
                [str(p), *spec], "refuse", 2, "computed inputs"
            )
    return rows


def _two_input_rows(d: Path, spec: list[str]) -> dict[str, Row]:
    """A module of two inputs concatenated in forward, through both torch ONNX exporters (a Concat of the two
    graph inputs) and torch.export (dynamic batch; a fixed one taking them as (b, a)), and inputs
    concatenated along the batch (refused)."""
    rows: dict[str, Row] = {}
    m = T._init(T.TwoInputs(), 103)
    ex, n = (torch.zeros(4, 2), torch.zeros(4, 1)), torch.export.Dim("N")
    p = d / "two_legacy.onnx"
    axes = {"a": {0: "N"}, "b": {0: "N"}}
    T._quiet(torch.onnx.export, m, ex, str(p), dynamo=False, input_names=["a", "b"], dynamic_axes=axes)
    rows["onnx legacy two inputs concatenated"] = Row(
        [str(p), *spec], "export", original=T.ort_two_inputs(p, 2)
    )
    p = d / "two_dynamo.onnx"
    T._quiet(torch.onnx.export, m, ex, str(p), dynamo=True, dynamic_shapes=({0: n}, {0: n}), verbose=False)
    rows["onnx dynamo two inputs concatenated"] = Row(
        [str(p), *spec], "export", original=T.ort_two_inputs(p, 2)
    )
    ep = T._quiet(torch.export.export, m, ex, dynamic_shapes=({0: n}, {0: n}))
    torch.export.save(ep, d / "two.pt2")
    rows[".pt2 two inputs concatenated"] = Row(
        [str(d / "two.pt2"), *spec], "export", original=T.torch_two_inputs(m, 2)
    )
    sw = T.TwoInputsSwapped(m).eval()
    torch.export.save(T._quiet(torch.export.export, sw, ex[::-1]), d / "two_swapped.pt2")
    rows[".pt2 two inputs concatenated, forward(b, a)"] = Row(
        [str(d / "two_swapped.pt2"), *spec], "export", original=T.torch_two_inputs(sw, 2, swap=True)
    )
    rj = T._init(T.RowsJoined(), 104)
    torch.export.save(
        T._quiet(torch.export.export, rj, (torch.zeros(4, 3), torch.ones(4, 3))), d / "two_rows.pt2"
    )
    rows[".pt2 two inputs concatenated along the batch (refused)"] = Row(
        [str(d / "two_rows.pt2"), *spec], "refuse", 2, "other than along the features"
    )
    p = d / "two_batch_cat.onnx"
    T.save_onnx(_batch_concat(), p)
    rows["onnx two inputs concatenated along the batch (refused)"] = Row(
        [str(p), *spec], "refuse", 2, "other than along the features"
    )
    return rows


def _batch_concat():
    """Two (N, 3) graph inputs concatenated along axis 0 (rows of both), then a dense layer."""
    w = T.weights(0)
    extra = [helper.make_tensor_value_info("b", TensorProto.FLOAT, ["N", T.N_IN])]
    nodes = [
        helper.make_node("Concat", ["x", "b"], ["c"], axis=0),
        helper.make_node("Gemm", ["c", "W2x", "B2"], ["y"], transB=1),
    ]
    return T.onnx_model(nodes, {"W2x": w["W1"][:1], "B2": w["B2"]}, extra_inputs=extra)


@pytest.fixture(scope="module")
def table(tmp_path_factory) -> dict[str, Row]:
    """Every idiom row, built once."""
    d = tmp_path_factory.mktemp("idioms")
    return _rows(d, ["--features", str(T.spec_file(d))])


NAMES = [
    "TorchScript with a torch.device attribute",
    "TorchScript torch.tensor constants",
    "TorchScript torch.tensor of mixed ints and floats (refused)",
    ".pt2 dynamic batch view(x.shape[0], -1)",
    "TorchScript scripted view(x.shape[0], -1)",
    "TorchScript traced view(x.shape[0], -1)",
    "onnx legacy view(x.shape[0], -1)",
    "onnx legacy reshape(x.shape[0] // 2, -1) (refused)",
    "onnx legacy two inputs concatenated",
    "onnx dynamo two inputs concatenated",
    "onnx two inputs concatenated along the batch (refused)",
    ".pt2 two inputs concatenated",
    ".pt2 two inputs concatenated, forward(b, a)",
    ".pt2 two inputs concatenated along the batch (refused)",
]


def test_table_is_complete(table):
    """Every built row is tested."""
    assert sorted(table) == sorted(NAMES)


def test_device_is_in_the_pickle(table):
    """The scripted file really names torch.device in its data.pkl (the class the allow-list admits)."""
    with zipfile.ZipFile(table[NAMES[0]].args[0]) as z:
        pkl = next(n for n in z.namelist() if n.endswith("/data.pkl"))
        assert "torch.device" in pickle_globals(z.read(pkl))


def _with_device(src: str, dst: Path, dev: str) -> None:
    """A copy of a scripted file whose data.pkl rebuilds its torch.device from `dev` instead of 'cpu' (the
    memoised 'cpu' the storages share is written out in full where they use it)."""
    cpu = b"X\x03\x00\x00\x00cpu"
    with zipfile.ZipFile(src) as z, zipfile.ZipFile(dst, "w") as out:
        for info in z.infolist():
            data = z.read(info.filename)
            if info.filename.endswith("/data.pkl"):
                m = re.search(rb"ctorch\ndevice\n(?:q.)?" + re.escape(cpu) + rb"q(.)\x85R", data, re.S)
                assert m is not None
                data = data[: m.start(1) - 1] + b"\x85R" + data[m.end(0) :]  # the device's 'cpu', unmemoised
                data = data.replace(b"h" + m.group(1), cpu)  # the storages' uses of the memo
                new = b"X" + struct.pack("<I", len(dev)) + dev.encode()
                data = data.replace(cpu + b"\x85R", new + b"\x85R", 1)
            out.writestr(info, data)


@pytest.mark.parametrize(("dev", "rc"), [("cpu", 0), ("not_a_device", 2)])
def test_device_string(dev, rc, table, tmp_path, capsys):
    """The device is rebuilt from its string: 'cpu' exports; a string that is no device is refused in one
    line (exit 2) by torch's C++ unpickler, nothing run."""
    bad = tmp_path / "device.pt"
    _with_device(table[NAMES[0]].args[0], bad, dev)
    args = ["export", str(bad), *table[NAMES[0]].args[1:], "--out", str(tmp_path / "out"), "--prefix", "m"]
    assert main(args) == rc
    err = capsys.readouterr().err.strip()
    assert rc == 0 or (len(err.splitlines()) == 1 and dev in err and str(bad) in err), err


@pytest.mark.parametrize("name", NAMES)
def test_idiom_row(name, table, tmp_path, capsys):
    """Exit 0 without --allow-pickle, and the integer reference within the proven bound (+ the float32
    margin) of the module's own forward on box points."""
    row = table[name]
    rc = main(["export", *row.args, "--out", str(tmp_path / "out"), "--prefix", "m"])
    err = capsys.readouterr().err
    if row.expect == "refuse":
        assert rc == row.code and len(err.strip().splitlines()) == 1 and row.message in err, err
        assert not (tmp_path / "out").exists()
        return
    assert rc == 0, err
    ex = prepare(row.args[0], prefix="m", features=row.args[2])
    qm = ex.qmodel
    x = box_points(qm, 500, seed=1)
    got = numpy_ref.infer(qm, quantize_features(qm, x)) * 2.0**-qm.out_frac
    mean, std = np.array(T.MEAN), np.array(T.STD)
    assert row.original is not None and ex.loaded is not None
    want = row.original((x - mean) / std) * T.OUT_STD + T.OUT_MEAN
    err = float(np.max(np.abs(got - want)))
    bound = f"bound {qm.error_bound:.3g} + margin {ex.loaded.margin:.3g}"
    print(f"{name}: max |integer - original| {err:.3g} <= {bound}")
    assert err <= qm.error_bound + ex.loaded.margin, name
