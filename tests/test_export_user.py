"""seagen export as a user meets it: bad input gets one line naming the file (exit 2, nothing written), a
disagreement with the original exits 1 and writes nothing, a bare network on its own inputs gets NAME_infer
alone. ~15 s on 2 cores."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import torch

from seagen.cli import main
from seagen.defaults import GENERATED
from seagen.modelfile import load_model
from tests import table_models as T

SF = GENERATED / "models" / "sf_calibration.pt"


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """A bare nn.Sequential with its features file, and broken variants of models and specs."""
    d = tmp_path_factory.mktemp("user")
    out = {"spec": T.spec_file(d), "seq": d / "seq.pt"}
    torch.save(T.seq(torch.nn.ReLU()), out["seq"])
    spec = json.loads(out["spec"].read_text())
    for name, change in {
        "flat": {"input_range": [[1.0, 1.0], *T.RANGE[1:]]},
        "badname": {"inputs": ["pot", "my input", "x2"]},
        "bare": {"inputs": ["x0", "x1", "x2"]},
        "typo": {"ouptut_std": 2.0},
        "twice": {"inputs": ["x0", "x0", "x2"]},
        "str_inputs": {"inputs": "u"},
        "nan_mean": {"mean": [float("nan"), 0.0, 0.0]},
        "inf_std": {"output_std": float("inf")},
        "case": {"inputs": ["a", "A", "x2"]},
    }.items():
        out[name] = d / f"{name}.json"
        out[name].write_text(json.dumps({**spec, **change}))
    (d / "broken.json").write_text("{inputs: nope")
    out["broken"] = d / "broken.json"
    (d / "binary.json").write_bytes(bytes(range(256)))
    out["binary"] = d / "binary.json"
    sf = load_model(SF)
    sf["sf"]["coef"] = sf["sf"]["coef"][:-1]
    torch.save(sf, d / "sf_short.pt")
    out["sf_short"] = d / "sf_short.pt"
    net = T.seq(torch.nn.ReLU())
    opt = torch.optim.Adam(net.parameters())
    torch.save(
        {"model_state_dict": net.state_dict(), "optimizer_state_dict": opt.state_dict(), "epoch": 3},
        d / "ckpt.pt",
    )
    torch.save(net.state_dict(), d / "sd.pt")
    torch.save({"weights": [1.0, 2.0]}, d / "other_dict.pt")
    out |= {"ckpt": d / "ckpt.pt", "sd": d / "sd.pt", "other_dict": d / "other_dict.pt"}
    for name, power in {"sf_frac": [0.5, 1], "sf_neg": [-1, 0], "sf_dup": [0, 0], "sf_deg": [13, 0]}.items():
        sf = load_model(SF)
        sf["sf"]["powers"][1] = power
        torch.save(sf, d / f"{name}.pt")
        out[name] = d / f"{name}.pt"
    (d / "a_dir.pt").mkdir()
    out["a_dir"] = d / "a_dir.pt"
    (d / "a_file").write_text("keep")
    out["a_file"] = d / "a_file"
    return out


OUT = ["--out", "{out}"]
BAD = {  # case: (arguments with {placeholders}, expected text, the file the message names)
    "out is a file": (["{sf}", "--out", "{a_file}"], "is not a directory", "a_file"),
    "out under a file": (["{sf}", "--out", "{a_file}/sub"], "a file, not a folder", "a_file"),
    "out in /proc": (["{sf}", "--out", "/proc/seagen_out"], "cannot write there", "/proc/seagen_out"),
    "empty prefix": (["{sf}", *OUT, "--prefix", ""], "--prefix is empty", ""),
    "prefix sea": (["{sf}", *OUT, "--prefix", "sea"], "belong to the C runtime", ""),
    "prefix sea_": (["{sf}", *OUT, "--prefix", "sea_cal"], "belong to the C runtime", ""),
    "range lo == hi": (["{seq}", "--features", "{flat}", *OUT], "needs lo < hi", "flat.json"),
    "sf lengths": (["{sf_short}", *OUT], "coefficients for", "sf_short.pt"),
    "bad input name": (["{seq}", "--features", "{badname}", *OUT], "not a C identifier", "badname.json"),
    "unparsable features": (["{seq}", "--features", "{broken}", *OUT], "cannot parse", "broken.json"),
    "unknown spec key": (["{seq}", "--features", "{typo}", *OUT], "unknown key(s) ouptut_std", "typo.json"),
    "no features": (["{seq}", *OUT], "needs --features", "seq.pt"),
    "input named twice": (
        ["{seq}", "--features", "{twice}", *OUT],
        "names 'x0' more than once",
        "twice.json",
    ),
    "model is a folder": (["{a_dir}", *OUT], "is a folder, not a model file", "a_dir"),
    "training checkpoint": (
        ["{ckpt}", "--features", "{spec}", *OUT],
        "a training checkpoint (model_state_dict, optimizer_state_dict, epoch): weights without the "
        "architecture, which seagen cannot read; pass the network itself: torch.save(model) of an "
        "nn.Sequential, torch.jit.script(model).save(...), torch.export.save(...) (.pt2) or "
        "torch.onnx.export",
        "ckpt.pt",
    ),
    "bare state_dict": (["{sd}", *OUT], "a bare state_dict (4 tensors such as '0.weight')", "sd.pt"),
    "other dict": (["{other_dict}", *OUT], "a dict but not a seagen model file", "other_dict.pt"),
    "sf fractional power": (["{sf_frac}", *OUT], "field 'sf.powers[1]' must be an integer", "sf_frac.pt"),
    "sf negative power": (["{sf_neg}", *OUT], "field 'sf.powers[1]' is [-1, 0]", "sf_neg.pt"),
    "sf repeated power": (["{sf_dup}", *OUT], "field 'sf.powers[1]' repeats [0, 0]", "sf_dup.pt"),
    "sf degree 13": (["{sf_deg}", *OUT], "i + j <= 12", "sf_deg.pt"),
    "inputs a string": (["{seq}", "--features", "{str_inputs}", *OUT], "must be a list", "str_inputs.json"),
    "mean NaN": (
        ["{seq}", "--features", "{nan_mean}", *OUT],
        "field 'mean[0]' must be finite",
        "nan_mean.json",
    ),
    "output std Inf": (
        ["{seq}", "--features", "{inf_std}", *OUT],
        "'output_std' must be finite",
        "inf_std.json",
    ),
    "names differ in case": (["{seq}", "--features", "{case}", *OUT], "differ only in case", "case.json"),
    "binary features": (["{seq}", "--features", "{binary}", *OUT], "not a text file", "binary.json"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_one_line_exit_2_nothing_written(case, files, tmp_path, capsys):
    """Each bad input: exit 2, one line naming the file, no traceback, no output folder, files untouched."""
    template, expect, names = BAD[case]
    out = tmp_path / "out"
    rc = main(["export", *(a.format(out=out, sf=SF, **files) for a in template)])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert len(err.strip().splitlines()) == 1 and expect in err and names in err, err
    assert "Traceback" not in err
    assert not out.exists()
    assert files["a_file"].read_text() == "keep"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_unwritable_out_exit_2(tmp_path, capsys):
    """An --out in a read-only folder: exit 2 naming it, nothing written."""
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    rc = main(["export", str(SF), "--out", str(ro / "x")])
    assert rc == 2 and "cannot write" in capsys.readouterr().err
    assert not (ro / "x").exists()


def test_stale_onnx_is_removed(files, tmp_path, capsys):
    """Re-exporting without --onnx removes NAME.onnx an earlier export left (it described another model)."""
    assert main(["export", str(SF), "--out", str(tmp_path), "--prefix", "m", "--onnx"]) == 0
    assert (tmp_path / "m.onnx").is_file()
    assert main(["export", str(SF), "--out", str(tmp_path), "--prefix", "m"]) == 0
    assert not (tmp_path / "m.onnx").exists() and (tmp_path / "m.c").is_file()


def test_misread_model_exits_1_and_writes_nothing(tmp_path, monkeypatch, capsys):
    """A frontend that misreads a one-sided Clip (drops its bound) is caught by the oracle against
    onnxruntime: exit 1, the first failing input with both outputs, no output folder."""
    import seagen.frontends.onnx_reader as reader

    onnx_path = T.save_onnx(T.graph_case("clip_min", 3), tmp_path / "clip.onnx")
    monkeypatch.setattr(
        reader, "clip_act", lambda op, p, lo, hi: reader.Act(op, p, "hardtanh", lo=-1e9, hi=1e9)
    )
    out = tmp_path / "out"
    rc = main(["export", str(onnx_path), "--features", str(T.spec_file(tmp_path)), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 1, err
    assert "integer" in err and "original" in err and "clip.onnx" in err
    assert not out.exists()


def test_failed_check_exits_1_and_writes_nothing(tmp_path, monkeypatch, capsys):
    """--check that finds a disagreement: exit 1 and nothing in --out."""
    import seagen.datacheck as dc

    bad = dc.DataReport([dc.Check("x", 1, {"C": "row 0"})], 0.0, "N", 0.0)
    monkeypatch.setattr(dc, "check_data_dir", lambda ex, d: bad)
    out = tmp_path / "out"
    assert main(["export", str(SF), "--out", str(out), "--check", str(tmp_path)]) == 1
    assert "MISMATCH" in capsys.readouterr().out
    assert not out.exists()


def test_bare_network_exports_infer_alone(files, tmp_path):
    """Inputs x0..x2 (not SEA features): NAME_infer only, no NAME_step or state; the C equals numpy."""
    from seagen.export import prepare
    from seagen.reference import numpy_ref
    from seagen.toolchain.equivalence import random_inputs
    from seagen.toolchain.model import CModel

    ex = prepare(str(files["seq"]), prefix="bare", features=str(files["bare"]))
    h = ex.files["bare.h"]
    assert "bare_infer" in h and "bare_step" not in h and "bare_state_t" not in h
    assert "bare_step" not in ex.files["bare.c"]
    assert any(line.startswith("NAME_infer only") and "x0, x1, x2" in line for line in ex.lines), ex.lines
    x = random_inputs(ex.qmodel, 2000, 0)
    assert np.array_equal(CModel(ex.files, "bare", ex.qmodel).infer(x), numpy_ref.infer(ex.qmodel, x))


@pytest.mark.parametrize("form", ["toml with BOM", "json with BOM", "json in UTF-16"])
def test_spec_files_as_editors_save_them(form, files, tmp_path, capsys):
    """A --features file saved with a byte order mark (Notepad's UTF-8, or its 'Unicode': UTF-16) and
    non-ASCII units: exported, the units spelled in ASCII in the C, as written in the manifest."""
    spec = json.loads(files["spec"].read_text()) | {"input_units": ["N\u00b7m", "\u00b0", "\u00b5m"]}
    spec["output_units"] = "\u03a9"
    if form.startswith("toml"):
        p = tmp_path / "spec.toml"
        text = "".join(f"{k} = {json.dumps(v, ensure_ascii=False)}\n" for k, v in spec.items())
    else:
        p, text = tmp_path / "spec.json", json.dumps(spec, ensure_ascii=False)
    p.write_bytes(text.encode("utf-16") if "UTF-16" in form else b"\xef\xbb\xbf" + text.encode())
    out = tmp_path / "out"
    rc = main(["export", str(files["seq"]), "--features", str(p), "--out", str(out), "--prefix", "m"])
    assert rc == 0, capsys.readouterr().err
    h = (out / "m.h").read_text()
    assert h.isascii() and "[N*m]" in h and "[deg]" in h and "[um]" in h and "[Ohm]" in h
    resolved = json.loads((out / "m.seagen.json").read_text())["resolved"]
    assert [i[1] for i in resolved["inputs"]] == spec["input_units"] and resolved["output"][1] == "\u03a9"


def test_onnx_external_data_outside_folder_refused(tmp_path, capsys):
    """An ONNX initializer whose external data points outside the model's folder: exit 2, nothing read."""
    from onnx import external_data_helper as ext

    model = T.gemm_graph("transB0", 5)
    inside = tmp_path / "model"
    inside.mkdir()
    ext.convert_model_to_external_data(
        model, all_tensors_to_one_file=True, location="w.bin", size_threshold=0
    )
    for t in model.graph.initializer:
        for e in t.external_data:
            if e.key == "location":
                e.value = "../w.bin"
    (inside / "m.onnx").write_bytes(
        model.SerializeToString()
    )  # onnx.save itself refuses '..'; a file may not
    (tmp_path / "w.bin").write_bytes(b"\0" * 4096)
    rc = main(
        [
            "export",
            str(inside / "m.onnx"),
            "--features",
            str(T.spec_file(tmp_path)),
            "--out",
            str(tmp_path / "o"),
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "outside the model folder" in err and "m.onnx" in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("case", ["missing", "truncated"])
def test_onnx_external_data_file_missing_or_short_says_so(case, tmp_path, capsys):
    """An ONNX model whose external data file was not copied along (or was cut short): exit 2, one line
    naming that file and saying it is missing (or too short), not that it lies outside the folder."""
    from onnx import external_data_helper as ext

    model = T.gemm_graph("transB0", 5)
    ext.convert_model_to_external_data(
        model, all_tensors_to_one_file=True, location="weights.bin", size_threshold=0
    )
    (tmp_path / "m.onnx").write_bytes(model.SerializeToString())  # the weights file is not written
    if case == "truncated":
        (tmp_path / "weights.bin").write_bytes(b"\0" * 8)
    spec, out = str(T.spec_file(tmp_path)), str(tmp_path / "o")
    rc = main(["export", str(tmp_path / "m.onnx"), "--features", spec, "--out", out])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "m.onnx" in err and "weights.bin" in err, err
    assert ("is missing" if case == "missing" else "cannot read external data") in err, err
    assert "outside" not in err and not (tmp_path / "o").exists()


def test_evaluate_refuses_pickles(tmp_path):
    """seagen evaluate loads model files without running code: a malicious pickle is refused, the payload
    never runs, and the message names --allow-pickle."""
    from seagen.errors import UserError
    from seagen.fit.evaluate import load_checked

    marker = tmp_path / "ran"
    torch.save({"format": "seagen-model/1", "x": T.Payload(marker)}, tmp_path / "evil.pt")
    with pytest.raises(UserError, match="--allow-pickle"):
        load_checked(tmp_path / "evil.pt")
    assert not marker.exists()


def test_default_models_load_weights_only():
    """generated/models/*.pt (a pickled nn.Sequential inside a dict) load with weights_only=True and the
    torch.nn allowlist: every global they name is on it."""
    from seagen.modelfile import nn_allowlist, safe_load

    allowed = {f"{c.__module__}.{c.__qualname__}" for c in nn_allowlist()}
    for p in sorted((GENERATED / "models").glob("*.pt")):
        assert set(torch.serialization.get_unsafe_globals_in_checkpoint(p)) <= allowed, p
        assert safe_load(p)["format"] == "seagen-model/1"
