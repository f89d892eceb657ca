"""Loading runs no code: crafted .pt2 and TorchScript archives are refused by the member that is not on the
allow-list, before torch sees the file (torch.export.load and torch.jit.load fail the test if reached), and
their payload marker stays absent; files are recognised by content, not by suffix. ~15 s on 2 cores."""

from __future__ import annotations

import contextlib
import io
import json
import os
import pickle
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
import torch
from torch import nn

from seagen.cli import main
from seagen.filekind import EXPORT, ONNX, PICKLE, TORCH_SAVE, TORCHSCRIPT, UNKNOWN, file_kind
from tests import table_models as T

MARKER_ENV = "SEAGEN_TEST_MARKER"
CONSTRUCTOR = r"""
#include <stdio.h>
#include <stdlib.h>
__attribute__((constructor)) static void ran(void) {
    const char *m = getenv("SEAGEN_TEST_MARKER");
    if (m) { FILE *f = fopen(m, "w"); if (f) fclose(f); }
}
"""


class Shell:
    """Unpickling this runs os.system (a GLOBAL of posix.system)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):  # noqa: D105
        return (os.system, (f"touch {self.marker}",))


class Eval:
    """Unpickling this runs builtins.eval."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):  # noqa: D105
        return (eval, (f"open({str(self.marker)!r}, 'w').close()",))


class WithSetstate(nn.Module):
    """A scripted module with a __setstate__, which torch.jit.load runs when it opens the file."""

    def __init__(self) -> None:
        super().__init__()
        self.fc = nn.Linear(T.N_IN, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # noqa: D102
        return self.fc(x)

    @torch.jit.export
    def __getstate__(self) -> tuple[torch.Tensor, bool]:  # noqa: D105
        return (self.fc.weight, self.training)

    @torch.jit.export
    def __setstate__(self, state: tuple[torch.Tensor, bool]) -> None:  # noqa: D105
        self.training = state[1]


def rewrite(src: Path, dst: Path, change=None, add: dict[str, bytes] | None = None) -> Path:
    """A copy of a zip archive with members changed by change(name, data) -> data and members added."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for info in zin.infolist():
            data = zin.read(info.filename)
            zout.writestr(info, change(info.filename, data) if change else data)
        for name, data in (add or {}).items():
            zout.writestr(name, data)
    return dst


def torch_bytes(obj) -> bytes:
    """torch.save of obj, as bytes."""
    buf = io.BytesIO()
    torch.save(obj, buf)
    return buf.getvalue()


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    """A small network saved as a .pt2 (m/...) and as TorchScript (s/...), and its --features file."""
    d = tmp_path_factory.mktemp("good")
    m = T.seq(nn.ReLU(), seed=3)
    torch.export.save(T._quiet(torch.export.export, m, T.example()), d / "m.pt2")
    T._quiet(torch.jit.script(m).save, str(d / "s.pt"))
    return {"pt2": d / "m.pt2", "script": d / "s.pt", "spec": T.spec_file(d), "module": m}


def old_layout(good, d: Path, marker: Path) -> Path:
    """The older .pt2 layout torch.export.load still reads, its example inputs a payload pickle."""
    from torch._export.serde.schema import SCHEMA_VERSION
    from torch._export.serde.serialize import serialize

    art = serialize(T._quiet(torch.export.export, good["module"], T.example()))
    p = d / "old.pt2"
    with zipfile.ZipFile(p, "w") as z:
        z.writestr("version", ".".join(map(str, SCHEMA_VERSION)))
        z.writestr("serialized_exported_program.json", art.exported_program)
        z.writestr("serialized_state_dict.pt", art.state_dict)
        z.writestr("serialized_constants.pt", art.constants)
        z.writestr("serialized_example_inputs.pt", torch_bytes({"x": T.Payload(marker)}))
    return p


def aoti(good, d: Path, marker: Path) -> Path:
    """A valid .pt2 with an AOTInductor package merged in: a shared object whose constructor writes the
    marker (torch.export.load dlopens it)."""
    if shutil.which("gcc") is None:
        pytest.skip("no gcc to build the shared object")
    (d / "evil.c").write_text(CONSTRUCTOR)
    subprocess.run(["gcc", "-shared", "-fPIC", "-o", str(d / "evil.so"), str(d / "evil.c")], check=True)
    extra = {
        "m/data/aotinductor/model/model.wrapper.so": (d / "evil.so").read_bytes(),
        "m/data/aotinductor/model/model.wrapper_metadata.json": json.dumps(
            {"AOTI_DEVICE_KEY": "cpu"}
        ).encode(),
    }
    return rewrite(good["pt2"], d / "aoti.pt2", add=extra)


def sympy_eval(good, d: Path, marker: Path) -> Path:
    """The current layout with a shape expression torch hands to sympy.sympify (which evaluates it)."""

    def change(name: str, data: bytes) -> bytes:
        if not name.endswith("models/model.json"):
            return data
        doc = json.loads(data)
        expr = f"__import__('pathlib').Path({str(marker)!r}).touch() or 4"
        values = doc["graph_module"]["graph"]["tensor_values"]
        batch = next(v for v in values.values() if v["sizes"][0] == {"as_int": 4})  # the input's batch
        batch["sizes"][0] = {"as_expr": {"expr_str": expr, "hint": {"as_int": 4}}}
        return json.dumps(doc).encode()

    return rewrite(good["pt2"], d / "sympy.pt2", change)


def opaque_constant(good, d: Path, marker: Path) -> Path:
    """A constants config entry of an opaque object, which torch.export.load reads with pickle.loads."""

    def change(name: str, data: bytes) -> bytes:
        if not name.endswith("model_constants_config.json"):
            return data
        meta = {"path_name": "opaque_obj_0", "is_param": False, "use_pickle": True, "tensor_meta": None}
        cfg = {"config": {"c": meta}}
        return json.dumps(cfg).encode()

    add = {"m/data/constants/opaque_obj_0": pickle.dumps(T.Payload(marker))}
    return rewrite(good["pt2"], d / "opaque.pt2", change, add)


def pickled_weight(good, d: Path, marker: Path) -> Path:
    """A weight stored as a pickle (use_pickle): a payload (torch reads it with weights_only=False)."""
    with zipfile.ZipFile(good["pt2"]) as z:
        cfg = json.loads(z.read("m/data/weights/model_weights_config.json"))
    cfg["config"]["0.bias"]["use_pickle"] = True
    member = "m/data/weights/" + cfg["config"]["0.bias"]["path_name"]

    def change(name: str, data: bytes) -> bytes:
        if name.endswith("model_weights_config.json"):
            return json.dumps(cfg).encode()
        return torch_bytes(T.Payload(marker)) if name == member else data

    return rewrite(good["pt2"], d / "pickled_weight.pt2", change)


def pt2_unknown(good, d: Path, marker: Path) -> Path:
    """A valid .pt2 with one unknown member added."""
    return rewrite(good["pt2"], d / "unknown.pt2", add={"m/data/notes.bin": b"\x00\x01"})


def script_unknown(good, d: Path, marker: Path) -> Path:
    """A valid TorchScript archive with one unknown member added."""
    return rewrite(
        good["script"], d / "unknown_script.pt", add={"s/bytecode.pkl": pickle.dumps(T.Payload(marker))}
    )


def script_global(cls):
    """A TorchScript archive whose data.pkl names a non-torch global (cls's reduce)."""

    def build(good, d: Path, marker: Path) -> Path:
        payload = pickle.dumps(cls(marker), protocol=2)
        return rewrite(
            good["script"], d / f"{cls.__name__}.pt", lambda n, b: payload if n == "s/data.pkl" else b
        )

    return build


def script_setstate(good, d: Path, marker: Path) -> Path:
    """TorchScript whose code defines __setstate__."""
    p = d / "setstate.pt"
    T._quiet(torch.jit.script(WithSetstate()).save, str(p))
    return p


# case -> (builder, the member the one line names, does torch itself run the payload on this file)
CASES = {
    "old .pt2 layout": (old_layout, "serialized_exported_program.json", True),
    "AOTInductor shared object": (aoti, "m/data/aotinductor/model/model.wrapper.so", True),
    "sympy shape expression": (sympy_eval, "m/models/model.json", True),
    "opaque constant": (opaque_constant, "model_constants_config.json", True),
    "pickled weight": (pickled_weight, "m/data/weights/weight_", True),
    ".pt2 + unknown member": (pt2_unknown, "m/data/notes.bin", False),
    "TorchScript + unknown member": (script_unknown, "s/bytecode.pkl", False),
    "TorchScript data.pkl names os.system": (script_global(Shell), "s/data.pkl", False),
    "TorchScript data.pkl names builtins.eval": (script_global(Eval), "s/data.pkl", False),
    "TorchScript code defines __setstate__": (script_setstate, "setstate/code/__torch__/", False),
}


@pytest.fixture
def no_torch_readers(monkeypatch):
    """torch.export.load and torch.jit.load fail the test if reached."""

    def reached(*_a, **_k):
        raise AssertionError("torch's reader was reached")

    monkeypatch.setattr(torch.export, "load", reached)
    monkeypatch.setattr(torch.jit, "load", reached)


@pytest.mark.parametrize("case", CASES)
def test_crafted_archive_refused(case, good, tmp_path, monkeypatch, capsys, no_torch_readers):
    """Refused with exit 2 and one line naming the member; nothing written; the payload did not run."""
    build, member, _ = CASES[case]
    marker = tmp_path / "payload_ran"
    monkeypatch.setenv(MARKER_ENV, str(marker))
    p = build(good, tmp_path, marker)
    out = tmp_path / "out"
    rc = main(["export", str(p), "--features", str(good["spec"]), "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2, err
    assert len(err.splitlines()) == 1 and member in err and str(p) in err and "--allow-pickle" in err, err
    assert not marker.exists(), "the payload ran"
    assert not out.exists()


@pytest.mark.parametrize("case", [c for c, (_b, _m, runs) in CASES.items() if runs])
def test_torch_itself_runs_these_payloads(case, good, tmp_path, monkeypatch):
    """The crafted files are real threats: torch.export.load runs their payload (what seagen never calls
    without --allow-pickle)."""
    build, _member, _ = CASES[case]
    marker = tmp_path / "payload_ran"
    monkeypatch.setenv(MARKER_ENV, str(marker))
    p = build(good, tmp_path, marker)
    with contextlib.suppress(Exception):  # the payload may run before torch fails on the rest of the file
        T._quiet(torch.export.load, str(p))
    assert marker.exists()


def test_valid_pt2_exports_without_torch_export_load(good, tmp_path, capsys, no_torch_readers):
    """The unmodified .pt2 exports, rebuilt from its JSON program and raw tensors; nothing is recorded as
    opted in."""
    rc = main(["export", str(good["pt2"]), "--features", str(good["spec"]), "--out", str(tmp_path / "a")])
    assert rc == 0, capsys.readouterr().err
    man = json.loads((tmp_path / "a" / "m.seagen.json").read_text())
    assert "allow_pickle" not in man["options"]


def test_allow_pickle_is_recorded(good, tmp_path, capsys):
    """--allow-pickle is the way past the allow-list, and the manifest records that it was used."""
    p = rewrite(good["pt2"], tmp_path / "extra.pt2", add={"m/data/notes.bin": b"\x00"})
    out = tmp_path / "out"
    rc = main(["export", str(p), "--features", str(good["spec"]), "--out", str(out), "--allow-pickle"])
    assert rc == 0, capsys.readouterr().err
    assert json.loads((out / "extra.seagen.json").read_text())["options"]["allow_pickle"] is True


def test_recognised_by_content(good, tmp_path, capsys):
    """An ONNX model named .ONNX, a TorchScript zip named .onnx and a .pt2 named .pt export; a text file
    named .onnx is refused in one line."""
    onnx_path = T.save_onnx(T.gemm_graph("transB0", 1), tmp_path / "model.ONNX")
    script_as_onnx = shutil.copy(good["script"], tmp_path / "script.onnx")
    pt2_as_pt = shutil.copy(good["pt2"], tmp_path / "program.pt")
    assert [file_kind(Path(p)) for p in (onnx_path, script_as_onnx, pt2_as_pt)] == [ONNX, TORCHSCRIPT, EXPORT]
    for i, p in enumerate((onnx_path, script_as_onnx, pt2_as_pt)):
        rc = main(["export", str(p), "--features", str(good["spec"]), "--out", str(tmp_path / f"o{i}")])
        assert rc == 0, capsys.readouterr().err
    text = tmp_path / "notes.onnx"
    text.write_text("not a model\n")
    assert file_kind(text) == UNKNOWN
    rc = main(["export", str(text), "--features", str(good["spec"]), "--out", str(tmp_path / "t")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "not a model file seagen reads" in err, err


def test_kinds_of_torch_files(tmp_path):
    """torch.save zips and plain pickles are told apart from archives by their members and first bytes."""
    torch.save({"w": torch.ones(2)}, tmp_path / "sd.onnx")
    (tmp_path / "p.bin").write_bytes(pickle.dumps([1, 2]))
    assert file_kind(tmp_path / "sd.onnx") == TORCH_SAVE
    assert file_kind(tmp_path / "p.bin") == PICKLE


@pytest.mark.parametrize("layer", [nn.CELU(), nn.LayerNorm(T.HIDDEN)])
def test_unsupported_layer_named(layer, good, tmp_path, capsys):
    """A whole-pickled Sequential with a torch.nn layer seagen does not export: the layer is named as
    unsupported, not 'pass --allow-pickle'."""
    p = tmp_path / "seq.pt"
    torch.save(T.seq(layer), p)
    rc = main(["export", str(p), "--features", str(good["spec"]), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    name = type(layer).__name__
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert f"torch.nn.{name}" in err and "does not export" in err and "pass --allow-pickle" not in err, err


def test_custom_class_named(good, tmp_path, capsys):
    """A custom module pickled whole: the class that stopped weights-only loading is named, with the
    --allow-pickle opt-in."""
    p = tmp_path / "func.pt"
    torch.save(T._init(T.Functional("tanh"), 2), p)
    rc = main(["export", str(p), "--features", str(good["spec"]), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert "tests.table_models.Functional" in err and "pass --allow-pickle" in err, err


def test_dynamic_batch_pt2_exports(good, tmp_path, capsys, no_torch_readers):
    """A .pt2 exported with a symbolic batch (its shape expressions are sympy srepr strings) passes the
    expression check and exports."""
    p = tmp_path / "dyn.pt2"
    ep = T._quiet(
        torch.export.export, good["module"], T.example(), dynamic_shapes=({0: torch.export.Dim("N")},)
    )
    torch.export.save(ep, p)
    rc = main(["export", str(p), "--features", str(good["spec"]), "--out", str(tmp_path / "o")])
    assert rc == 0, capsys.readouterr().err


@pytest.mark.parametrize(
    "expr, ok",
    [
        ("Symbol('s31', positive=True, integer=True)", True),
        ("Add(Integer(1), Mul(Integer(2), Symbol('s0', integer=True)))", True),
        ("Max(1, s0) >= 2", True),
        ("Float('0.5', precision=53)", True),
        ("__import__('os').system('true')", False),
        ("open('x', 'w')", False),
        ("Symbol('s0').func('x')", False),
        ("getattr(Symbol, 'x')", False),
        ("(lambda: 1)()", False),
        ("Symbol('a b')", False),
    ],
)
def test_shape_expressions(expr, ok):
    """Shape expressions torch writes pass; anything sympify's eval could turn into another call does not."""
    from seagen.frontends.archives import plain_sym_expr

    assert plain_sym_expr(expr) is ok


def pt2_from_file(good, d: Path, marker: Path) -> Path:
    """A valid .pt2 whose program holds a dead aten.from_file node (shared=True creates the file when the
    node runs: constant folding or the oracle's forward would run it)."""

    def change(name: str, data: bytes) -> bytes:
        if not name.endswith("models/model.json"):
            return data
        doc = json.loads(data)
        graph = doc["graph_module"]["graph"]
        args = [
            ("filename", {"as_string": str(marker)}),
            ("shared", {"as_bool": True}),
            ("size", {"as_int": 8}),
        ]
        graph["nodes"].insert(
            0,
            {
                "target": "torch.ops.aten.from_file.default",
                "inputs": [{"name": k, "arg": v, "kind": 1} for k, v in args],
                "outputs": [{"as_tensor": {"name": "pwn"}}],
                "metadata": {},
                "is_hop_single_tensor_return": None,
                "name": "pwn",
            },
        )
        graph["tensor_values"]["pwn"] = {
            "dtype": 7,
            "sizes": [{"as_int": 8}],
            "requires_grad": False,
            "device": {"type": "cpu", "index": None},
            "strides": [{"as_int": 1}],
            "storage_offset": {"as_int": 0},
            "layout": 7,
        }
        return json.dumps(doc).encode()

    return rewrite(good["pt2"], d / "from_file.pt2", change)


def script_from_file(good, d: Path, marker: Path) -> Path:
    """TorchScript whose forward reads a file with aten::from_file (shared: it creates the file), its result
    multiplied by zero so the output does not change."""
    src = d / "ff_module.py"
    src.write_text(
        "import torch\n\n\n"
        "class M(torch.nn.Module):\n"
        "    def __init__(self):\n"
        "        super().__init__()\n"
        f"        self.fc = torch.nn.Linear({T.N_IN}, 1)\n\n"
        "    def forward(self, x):\n"
        f"        y = torch.from_file({str(marker)!r}, True, 8)\n"
        "        return self.fc(x) + y.sum() * 0.0\n"
    )
    import importlib.util

    spec = importlib.util.spec_from_file_location("ff_module", src)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    p = d / "from_file_script.pt"
    T._quiet(torch.jit.script(mod.M().eval()).save, str(p))
    return p


@pytest.mark.parametrize("build", [pt2_from_file, script_from_file], ids=["pt2", "torchscript"])
def test_graph_with_file_io_refused_before_it_runs(build, good, tmp_path, capsys):
    """A graph op that is neither read nor known to be pure (aten.from_file, even in a dead node or times
    zero) is refused by name before any node runs: exit 2, one line, nothing written, no file created."""
    marker = tmp_path / "created_by_the_model"
    p = build(good, tmp_path, marker)
    assert not marker.exists()
    out = tmp_path / "out"
    rc = main(["export", str(p), "--features", str(good["spec"]), "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "from_file" in err and str(p) in err, err
    assert not marker.exists(), "the model's file I/O ran"
    assert not out.exists()


def _script_member(good, suffix: str) -> str:
    """The full name of the TorchScript archive's member for `suffix` (a module's source file; a process
    that scripted the same class before names it `suffix-without-.py/___torch_mangle_N.py`)."""
    stem, ext = suffix.rsplit(".", 1)
    pattern = rf"(^|/){re.escape(stem)}(/___torch_mangle_\d+)?\.{re.escape(ext)}$"
    with zipfile.ZipFile(good["script"]) as z:
        return next(n for n in z.namelist() if re.search(pattern, n))


def ts_carriage_return(good, d: Path) -> Path:
    """A lone carriage return in a TorchScript source comment (Python ends the line there, TorchScript's
    lexer does not: the two read different code)."""
    code = _script_member(good, "code/__torch__/torch/nn/modules/container.py")

    def change(name: str, data: bytes) -> bytes:
        return data.replace(b"\n", b"  # x\r  \n", 1) if name == code else data

    return rewrite(good["script"], d / "cr.pt", change)


def ts_setstate_text(good, d: Path) -> Path:
    """The name __setstate__ anywhere in TorchScript source (here in a comment)."""
    code = _script_member(good, "code/__torch__/torch/nn/modules/container.py")
    return rewrite(
        good["script"], d / "setstate_text.pt", lambda n, b: b + b"# __setstate__\n" if n == code else b
    )


def ts_prepended(good, d: Path) -> Path:
    """Bytes before the first member: Python's zipfile reads past them, other readers take offsets as
    written (the room a second central directory needs)."""
    p = d / "prepended.pt"
    p.write_bytes(b"PK\x03\x04" + b"\0" * 60 + good["script"].read_bytes())
    return p


def ts_torchbind(good, d: Path) -> Path:
    """data.pkl naming a torchbind class (its C++ __setstate__ runs when torch loads it)."""
    name = _script_member(good, "data.pkl")
    payload = b"\x80\x02c__torch__.torch.classes.quantized\nLinearPackedParamsBase\nq\x00."
    return rewrite(good["script"], d / "torchbind.pt", lambda n, b: payload if n == name else b)


@pytest.mark.parametrize(
    "build,words",
    [
        (ts_carriage_return, "read differently"),
        (ts_setstate_text, "__setstate__"),
        (ts_prepended, "not a zip archive seagen reads"),
        (ts_torchbind, "torch.classes"),
    ],
    ids=["carriage return", "__setstate__ in text", "prepended bytes", "torchbind class"],
)
def test_torchscript_ambiguities_refused(build, words, good, tmp_path, capsys, no_torch_readers):
    """What Python and torch could read differently (a lone CR, a second directory) and code torch runs on
    load in any form is refused in one line before torch.jit.load is reached."""
    p = build(good, tmp_path)
    rc = main(["export", str(p), "--features", str(good["spec"]), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and words in err and str(p) in err, err
    assert not (tmp_path / "out").exists()


def test_torch_reads_the_checked_bytes(good, tmp_path, capsys):
    """A valid TorchScript file still exports: torch.jit.load gets the checked members, repacked."""
    rc = main(["export", str(good["script"]), "--features", str(good["spec"]), "--out", str(tmp_path / "o")])
    assert rc == 0, capsys.readouterr().err
