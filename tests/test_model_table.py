"""The model table: models from real producers are exported right (checked against the original) or refused
with a reason (exit code + one-line message); malicious files never run their payload. ~45 s on 2 cores."""

from __future__ import annotations

import pickle
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
from torch import nn

from seagen.cli import main
from seagen.export import prepare
from seagen.reference import numpy_ref
from seagen.reference.float_ref import quantize_features
from seagen.reference.oracle import box_points
from tests import table_models as T
from tests import table_onnx_idioms as I
from tests.table_models import Row

PT2_EXPORTED = (
    "hardtanh_affine", "affine_after_act", "affine_after_last", "clamp_min", "clamp_max", "alpha_arith",
    "addmm_scaled", "add_self", "leaky_negative", "clamp_inverted",
)  # fmt: skip
PT2_REFUSED = {
    "residual": "computed inputs",
    "shared": "called twice",
    "stacked": "stacked",
    "celu": "unsupported op",
    "mul_self": "a product of two computed values",
    "leaky_steep": "LeakyReLU slope 1.5",
}
ONNX_GRAPHS = (
    "add_after_relu", "clip_min", "clip_max", "clip_attr", "dead_branch", "out_of_order", "clip_inverted",
    "clip_shape_1", "leaky_negative", "add_self", "fixed_batch_1", "float16",
)  # fmt: skip
ONNX_REFUSED = {
    "stacked": "stacked",
    "residual": "computed inputs",
    "weight_input": "inputs (x, W1)",
    "mul_self": "a product of two computed values",
    "leaky_steep": "LeakyReLU slope 3.0",
}
ACTS = {
    "relu": nn.ReLU(),
    "leaky": nn.LeakyReLU(0.1),
    "hardtanh": nn.Hardtanh(-0.5, 0.8),
    "tanh": nn.Tanh(),
    "sigmoid": nn.Sigmoid(),
    "relu6": nn.ReLU6(),
    "gelu": nn.GELU(),  # the smooth ones: every form in tests/test_smooth_activations.py
    "prelu": nn.PReLU(T.HIDDEN),
}


def _torch_rows(d: Path, spec: list[str]) -> dict[str, Row]:
    """nn.Sequential saved whole, custom modules pickled/scripted/traced/.pt2, graphs seagen must refuse."""
    rows: dict[str, Row] = {}
    for i, (name, act) in enumerate(ACTS.items()):
        m = T.seq(act, seed=i)
        torch.save(m, d / f"seq_{name}.pt")
        rows[f"sequential {name}"] = Row(
            [str(d / f"seq_{name}.pt"), *spec], "export", original=T.torch_original(m)
        )
    m = T.seq(nn.BatchNorm1d(T.HIDDEN), nn.ReLU(), nn.Dropout(0.3), nn.Identity(), nn.Flatten(), seed=7)
    torch.save(m, d / "seq_bn.pt")
    rows["sequential batchnorm dropout identity"] = Row(
        [str(d / "seq_bn.pt"), *spec], "export", original=T.torch_original(m)
    )
    shared = nn.Linear(T.HIDDEN, T.HIDDEN)
    torch.save(T.seq(nn.ReLU(), shared, nn.ReLU(), shared, seed=8), d / "seq_shared.pt")
    rows["sequential Linear used twice (refused)"] = Row(
        [str(d / "seq_shared.pt"), *spec], "refuse", 2, "called twice"
    )
    f = T._init(T.Functional("tanh"), 8)
    torch.save(f, d / "func.pt")
    rows["custom module pickled (refused)"] = Row([str(d / "func.pt"), *spec], "refuse", 2, "--allow-pickle")
    rows["custom module pickled --allow-pickle"] = Row(
        [str(d / "func.pt"), *spec, "--allow-pickle"], "export", original=T.torch_original(f)
    )
    T._quiet(torch.jit.script(f).save, str(d / "func_script.pt"))
    rows["custom module TorchScript scripted"] = Row(
        [str(d / "func_script.pt"), *spec], "export", original=T.torch_original(f)
    )
    g = T._init(T.Functional("leaky"), 9)
    T._quiet(torch.jit.trace, g, T.example()).save(str(d / "func_trace.pt"))
    rows["custom module TorchScript traced"] = Row(
        [str(d / "func_trace.pt"), *spec], "export", original=T.torch_original(g)
    )
    for i, kind in enumerate(PT2_EXPORTED):
        m = T._init(T.Lambda(kind), 10 + i)
        torch.export.save(T._quiet(torch.export.export, m, T.example()), d / f"{kind}.pt2")
        rows[f".pt2 {kind}"] = Row([str(d / f"{kind}.pt2"), *spec], "export", original=T.torch_original(m))
    for i, (kind, msg) in enumerate(PT2_REFUSED.items()):
        m = T._init(T.Lambda(kind), 20 + i)
        torch.export.save(T._quiet(torch.export.export, m, T.example()), d / f"{kind}.pt2")
        rows[f".pt2 {kind} (refused)"] = Row([str(d / f"{kind}.pt2"), *spec], "refuse", 2, msg)
    m = T._init(T.Lambda("stacked"), 30)
    T._quiet(torch.jit.script(m).save, str(d / "stacked_script.pt"))
    rows["TorchScript stacked (refused)"] = Row([str(d / "stacked_script.pt"), *spec], "refuse", 2, "stacked")
    rows.update(_mode_dtype_rows(d, spec))
    return rows


def _mode_dtype_rows(d: Path, spec: list[str]) -> dict[str, Row]:
    """Modules saved in training mode (scripted: read in eval mode; traced: dropout baked in, refused) and
    float16 / bfloat16 modules (checked with a margin from their own float type)."""
    rows: dict[str, Row] = {}
    m = T._init(T.Dropped(), 31).train()
    T._quiet(torch.jit.script(m).save, str(d / "dropout_train_script.pt"))
    rows["TorchScript scripted in training mode"] = Row(
        [str(d / "dropout_train_script.pt"), *spec], "export", original=T.torch_original(m)
    )
    m = T._init(T.Dropped(), 32).train()
    T._quiet(lambda: torch.jit.trace(m, T.example(), check_trace=False).save(str(d / "dropout_trace.pt")))
    rows["TorchScript traced in training mode (refused)"] = Row(
        [str(d / "dropout_trace.pt"), *spec], "refuse", 2, "Dropout in training mode"
    )
    for name, dtype in (("float16", torch.float16), ("bfloat16", torch.bfloat16)):
        m = T.seq(nn.Tanh(), seed=33).to(dtype)
        torch.save(m, d / f"seq_{name}.pt")
        rows[f"sequential {name}"] = Row([str(d / f"seq_{name}.pt"), *spec], "export", original=_cast_run(m))
    return rows


def _cast_run(m: nn.Module):
    """A low-precision module's own forward on inputs cast to its type."""
    dtype = next(m.parameters()).dtype

    def run(x: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return m(torch.from_numpy(np.asarray(x, np.float64)).to(dtype)).double().numpy()[:, 0]

    return run


def _malicious_rows(d: Path, spec: list[str]) -> dict[str, Row]:
    """Files whose unpickling would touch a marker file: refused, marker absent."""
    rows: dict[str, Row] = {}
    mk = d / "markers"
    mk.mkdir()
    torch.save(T.Payload(mk / "torch_save"), d / "evil_torch.pt")
    rows["malicious torch.save (refused)"] = Row(
        [str(d / "evil_torch.pt"), *spec], "refuse", 2, "--allow-pickle", marker=mk / "torch_save"
    )
    (d / "evil_plain.pt").write_bytes(pickle.dumps(T.Payload(mk / "plain")))
    rows["malicious plain pickle (refused)"] = Row(
        [str(d / "evil_plain.pt"), *spec], "refuse", 2, "--allow-pickle", marker=mk / "plain"
    )
    good = T.seq(nn.ReLU(), seed=40)
    torch.save(
        {"format": "seagen-model/1", "kind": "mlp", "module": good, "metrics": T.Payload(mk / "dict")},
        d / "evil_dict.pt",
    )
    rows["malicious seagen model.pt (refused)"] = Row(
        [str(d / "evil_dict.pt"), *spec], "refuse", 2, "--allow-pickle", marker=mk / "dict"
    )
    torch.export.save(T._quiet(torch.export.export, good, T.example()), d / "good.pt2")
    T.pt2_with_bad_sample(d / "good.pt2", d / "evil.pt2", mk / "pt2")
    rows["malicious .pt2 sample inputs (refused)"] = Row(
        [str(d / "evil.pt2"), *spec], "refuse", 2, "--allow-pickle", marker=mk / "pt2"
    )
    return rows


def _onnx_rows(d: Path, spec: list[str]) -> dict[str, Row]:
    """Torch's two ONNX exporters, skl2onnx, and hand-built graphs in every Gemm form."""
    rows: dict[str, Row] = {}
    f = T._init(T.Functional("tanh"), 50)
    T._quiet(
        torch.onnx.export,
        f,
        T.example(),
        str(d / "legacy.onnx"),
        dynamo=False,
        input_names=["x"],
        dynamic_axes={"x": {0: "N"}},
    )
    rows["torch.onnx.export legacy"] = Row(
        [str(d / "legacy.onnx"), *spec], "export", original=T.ort_original(d / "legacy.onnx")
    )
    m = T._init(T.Lambda("affine_after_act"), 51)
    T._quiet(
        torch.onnx.export,
        m,
        T.example(),
        str(d / "dynamo.onnx"),
        dynamo=True,
        dynamic_shapes=({0: torch.export.Dim("N")},),
        verbose=False,
    )
    rows["torch.onnx.export dynamo"] = Row(
        [str(d / "dynamo.onnx"), *spec], "export", original=T.ort_original(d / "dynamo.onnx")
    )
    T._quiet(torch.onnx.export, f, T.example(), str(d / "legacy_fixed.onnx"), dynamo=False, input_names=["x"])
    rows["torch.onnx.export legacy fixed batch"] = Row(
        [str(d / "legacy_fixed.onnx"), *spec], "export", original=T.ort_original(d / "legacy_fixed.onnx")
    )
    T._quiet(torch.onnx.export, m, T.example(), str(d / "dynamo_fixed.onnx"), dynamo=True, verbose=False)
    rows["torch.onnx.export dynamo fixed batch"] = Row(
        [str(d / "dynamo_fixed.onnx"), *spec], "export", original=T.ort_original(d / "dynamo_fixed.onnx")
    )
    rows["skl2onnx MLPRegressor"] = _sklearn_row(d, spec)
    rows["skl2onnx MLPRegressor fixed batch"] = _sklearn_row(d, spec, batch=1)
    for i, form in enumerate(("transB0", "alpha_beta", "bias_1n", "no_bias", "matmul_add")):
        p = T.save_onnx(T.gemm_graph(form, 60 + i), d / f"gemm_{form}.onnx")
        rows[f"onnx {form}"] = Row([str(p), *spec], "export", original=T.ort_original(p))
    for i, kind in enumerate(ONNX_GRAPHS):
        p = T.save_onnx(T.graph_case(kind, 70 + i), d / f"graph_{kind}.onnx")
        dtype = np.float16 if kind == "float16" else np.float32
        rows[f"onnx {kind}"] = Row([str(p), *spec], "export", original=T.ort_original(p, dtype))
    for kind, msg in ONNX_REFUSED.items():
        p = T.save_onnx(T.graph_case(kind, 80), d / f"graph_{kind}.onnx")
        rows[f"onnx {kind} (refused)"] = Row([str(p), *spec], "refuse", 2, msg)
    return rows | _idiom_rows(d, spec)


def _idiom_rows(d: Path, spec: list[str]) -> dict[str, Row]:
    """Converters' idioms (tests/table_onnx_idioms.py): Max/Min by a number, batch bookkeeping at the ends,
    a float16 body between Casts; each checked against onnxruntime on the graph as written, or refused."""
    rows: dict[str, Row] = {}
    for i, kind in enumerate([*I.EXPORTED, *I.REFUSED]):
        p = T.save_onnx(I.idiom_case(kind, 90 + i), d / f"idiom_{i}.onnx")
        if kind in I.REFUSED:
            rows[f"onnx idiom {kind} (refused)"] = Row([str(p), *spec], "refuse", 2, I.REFUSED[kind])
        else:
            rows[f"onnx idiom {kind}"] = Row([str(p), *spec], "export", original=T.ort_original(p))
    return rows


def _sklearn_row(d: Path, spec: list[str], batch: int | None = None) -> Row:
    """An MLPRegressor fitted on normalised inputs, converted by skl2onnx (it adds a Cast node); `batch`
    fixes the batch dimension of the graph input."""
    from skl2onnx import to_onnx
    from skl2onnx.common.data_types import FloatTensorType
    from sklearn.neural_network import MLPRegressor

    rng = np.random.default_rng(0)
    x = rng.normal(size=(200, T.N_IN)).astype(np.float32)
    y = np.tanh(x @ np.array([0.5, -1.0, 0.3])) + 0.1 * x[:, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reg = MLPRegressor(hidden_layer_sizes=(T.HIDDEN, T.HIDDEN), max_iter=50, random_state=0).fit(x, y)
    types = None if batch is None else [("X", FloatTensorType([batch, T.N_IN]))]
    p = d / ("sk.onnx" if batch is None else f"sk_batch{batch}.onnx")
    p.write_bytes(to_onnx(reg, x[:1] if types is None else None, initial_types=types).SerializeToString())
    return Row([str(p), *spec], "export", original=T.ort_original(p))


@pytest.fixture(scope="session")
def table(tmp_path_factory) -> dict[str, Row]:
    """Every model of the table, built once per session."""
    d = tmp_path_factory.mktemp("table")
    spec = ["--features", str(T.spec_file(d))]
    return {**_torch_rows(d, spec), **_malicious_rows(d, spec), **_onnx_rows(d, spec)}


ROW_NAMES = [
    *(f"sequential {a}" for a in ACTS),
    "sequential batchnorm dropout identity",
    "sequential Linear used twice (refused)",
    "custom module pickled (refused)",
    "custom module pickled --allow-pickle",
    "custom module TorchScript scripted",
    "custom module TorchScript traced",
    *(f".pt2 {k}" for k in PT2_EXPORTED),
    *(f".pt2 {k} (refused)" for k in PT2_REFUSED),
    "TorchScript stacked (refused)",
    "TorchScript scripted in training mode",
    "TorchScript traced in training mode (refused)",
    "sequential float16",
    "sequential bfloat16",
    "malicious torch.save (refused)",
    "malicious plain pickle (refused)",
    "malicious seagen model.pt (refused)",
    "malicious .pt2 sample inputs (refused)",
    "torch.onnx.export legacy",
    "torch.onnx.export dynamo",
    "torch.onnx.export legacy fixed batch",
    "torch.onnx.export dynamo fixed batch",
    "skl2onnx MLPRegressor",
    "skl2onnx MLPRegressor fixed batch",
    *(f"onnx {f}" for f in ("transB0", "alpha_beta", "bias_1n", "no_bias", "matmul_add")),
    *(f"onnx {k}" for k in ONNX_GRAPHS),
    *(f"onnx {k} (refused)" for k in ONNX_REFUSED),
    *(f"onnx idiom {k}" for k in I.EXPORTED),
    *(f"onnx idiom {k} (refused)" for k in I.REFUSED),
]


def test_table_is_complete(table):
    """The table has at least 30 rows and every built row is tested."""
    assert len(table) >= 30
    assert sorted(table) == sorted(ROW_NAMES)


def _physical_original(row: Row):
    """The row's original on physical inputs: the feature normalisation the spec states around it."""
    mean, std = np.array(T.MEAN), np.array(T.STD)
    return lambda x: row.original((x - mean) / std) * T.OUT_STD + T.OUT_MEAN


@pytest.mark.parametrize("name", ROW_NAMES)
def test_row(name, table, tmp_path, capsys):
    """Exported rows: exit 0, and the integer reference is within the proven bound (+ the stated float32
    margin) of the original run by the test's own runtime on box points. Refused rows: the exit code, one
    line naming the file and the reason, nothing written, and no payload ran."""
    row = table[name]
    out = tmp_path / "out"
    rc = main(["export", *row.args, "--out", str(out), "--prefix", "m"])
    err = capsys.readouterr().err
    if row.expect == "refuse":
        assert rc == row.code, err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and row.message in err and row.args[0] in err, err
        assert not out.exists()
        if row.marker is not None:
            assert not row.marker.exists(), "the pickle payload ran"
        return
    assert rc == 0, err
    assert (out / "m.c").is_file()
    ex = prepare(row.args[0], prefix="m", features=row.args[2], allow_pickle="--allow-pickle" in row.args)
    qm = ex.qmodel
    x = box_points(qm, 500, seed=1)
    got = numpy_ref.infer(qm, quantize_features(qm, x)) * 2.0**-qm.out_frac
    want = _physical_original(row)(x)
    assert ex.loaded is not None
    assert np.max(np.abs(got - want)) <= qm.error_bound + ex.loaded.margin, name
