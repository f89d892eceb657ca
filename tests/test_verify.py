"""`seagen verify` checks committed C against its model: drift by file, numbers bit for bit, exit codes."""

from __future__ import annotations

import json
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from seagen.cli import main
from seagen.defaults import GENERATED, default_model
from seagen.testing import assert_equivalent
from tests.conftest import EXAMPLE_ACTUATOR, run_cli

CAL = default_model("mlp_calibration")


def one_export(tmp_path: Path) -> Path:
    """A folder holding only the cal_mlp export (copied from generated/)."""
    out = tmp_path / "fw"
    out.mkdir()
    manifest = GENERATED / "cal_mlp.seagen.json"
    for name in [*json.loads(manifest.read_text())["files"], manifest.name]:
        (out / name).parent.mkdir(parents=True, exist_ok=True)  # the package's zephyr/, examples/NAME/
        shutil.copy(GENERATED / name, out / name)
    return out


def run(*args: str) -> tuple[int, str, str]:
    """`seagen ARGS` (in this process): exit code, stdout, stderr."""
    return run_cli(*args)


@pytest.mark.parametrize("name", ["mlp_calibration", "mlp_control", "sf_calibration", "sf_control"])
def test_generated_passes(name, capsys):
    """Every default export in generated/ verifies against its model: exit 0."""
    assert main(["verify", str(GENERATED), "--model", str(default_model(name)), "--vectors", "2000"]) == 0
    assert "agrees" in capsys.readouterr().out


def test_one_number_edit_of_a_weight_fails_naming_the_file(tmp_path, capsys):
    """Changing one weight in NAME.c: exit 1, the file is named as edited and the numbers disagree."""
    out = one_export(tmp_path)
    c = (out / "cal_mlp.c").read_text()
    m = re.search(r"(cal_mlp_w0\[[^{]*\{\s*)(-?\d+)", c)
    assert m
    edited = c[: m.start(2)] + str(int(m.group(2)) + 1) + c[m.end(2) :]
    (out / "cal_mlp.c").write_text(edited)
    assert main(["verify", str(out), "--model", str(CAL), "--vectors", "500"]) == 1
    text = capsys.readouterr().out
    assert f"{out / 'cal_mlp.c'}: edited since export" in text
    assert re.search(r"FAIL cal_mlp_infer .*C differs at row \d+, input \[", text), text


def test_a_different_model_fails(tmp_path, capsys):
    """Verifying the only export of a folder against another model: exit 1, both models named."""
    out = one_export(tmp_path)
    assert main(["verify", str(out), "--model", str(default_model("mlp_control"))]) == 1
    text = capsys.readouterr().out
    assert "mlp_control.pt" in text and "is not the model cal_mlp.seagen.json was exported from" in text


@pytest.mark.parametrize(
    "args, message",
    [
        (["verify", "no/such/dir", "--model", str(CAL)], "no/such/dir: no such export folder"),
        (["verify", str(GENERATED), "--model", "nope.pt"], "nope.pt: no such model file"),
        (["verify", str(GENERATED), "--model", __file__], "no export of test_verify.py among"),
        (["verify", str(GENERATED), "--model", str(CAL), "--prefix", "zz"], "no export 'zz'"),
        (["verify", str(GENERATED), "--model", str(CAL), "--vectors", "-1"], "--vectors must be >= 0"),
    ],
    ids=["missing folder", "missing model", "no match among several", "unknown prefix", "negative vectors"],
)
def test_bad_input_exits_2(args, message):
    """Bad input: exit 2, one message naming the problem, no traceback."""
    code, _, err = run(*args)
    assert code == 2 and message in err and "Traceback" not in err, err


def test_junit_has_one_case_per_check(tmp_path):
    """--junit writes XML that parses, one test case per check, failures marked."""
    out = one_export(tmp_path)
    (out / "cal_mlp.h").write_text((out / "cal_mlp.h").read_text() + "extern int cal_mlp_extra;\n")
    report = tmp_path / "verify.xml"
    code, stdout, _ = run("verify", str(out), "--model", str(CAL), "--vectors", "200", "--junit", str(report))
    assert code == 1
    suite = ET.parse(report).getroot()
    cases = suite.findall("testcase")
    assert len(cases) == int(suite.get("tests", "0")) == len(re.findall(r"^  (ok  |FAIL) ", stdout, re.M))
    failed = [c.get("name") for c in cases if c.find("failure") is not None]
    assert failed == ["cal_mlp.h unchanged"]


def test_other_seagen_version_warns_and_changed_quantization_fails(tmp_path, capsys):
    """A manifest from another seagen version passes with a warning; a quantization change exits 1."""
    out = one_export(tmp_path)
    man = out / "cal_mlp.seagen.json"
    doc = json.loads(man.read_text())
    doc["seagen_version"] = "0.0.9"
    man.write_text(json.dumps(doc))
    assert main(["verify", str(out), "--model", str(CAL), "--vectors", "200", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["ok"] and "seagen 0.0.9" in result["warnings"][0]
    doc["resolved"]["qmodel_hash"] = "0" * 16
    man.write_text(json.dumps(doc))
    assert main(["verify", str(out), "--model", str(CAL), "--vectors", "200"]) == 1
    assert "re-export" in capsys.readouterr().out


def test_missing_file_is_named(tmp_path, capsys):
    """A file of the export deleted: exit 1, the file named as missing, no attempt to build."""
    out = one_export(tmp_path)
    (out / "sea_fixed.h").unlink()
    assert main(["verify", str(out), "--model", str(CAL)]) == 1
    assert f"{out / 'sea_fixed.h'}: missing" in capsys.readouterr().out


def test_assert_equivalent_raises_with_the_report(tmp_path):
    """seagen.testing.assert_equivalent passes on a good export and raises with the report on an edit."""
    out = one_export(tmp_path)
    assert_equivalent(str(out), str(CAL), vectors=200)
    (out / "sea_nn.c").write_text((out / "sea_nn.c").read_text() + "typedef int sea_nn_extra;\n")
    with pytest.raises(AssertionError, match="sea_nn.c: edited since export"):
        assert_equivalent(str(out), str(CAL), vectors=200)


def test_cortex_m4_core(tmp_path, capsys):
    """--core cortex-m4 builds the C on disk with arm-none-eabi-gcc and runs it in unicorn: exit 0."""
    pytest.importorskip("unicorn")
    from seagen.toolchain.cortexm import toolchain_missing

    if msg := toolchain_missing():
        pytest.skip(msg)
    out = one_export(tmp_path)
    assert main(["verify", str(out), "--model", str(CAL), "--vectors", "300", "--core", "cortex-m4"]) == 0
    assert "(cortex-m4)" in capsys.readouterr().out


def test_controller_export_ticks_checked(tmp_path, capsys):
    """An export with --controller: its NAME_controller_tick equals the controller twin; a changed gain in
    NAME_controller.c is named as an edit and its ticks disagree (exit 1)."""
    model = default_model("mlp_control")
    assert main(["export", str(model), "--prefix", "ctl_mlp", "--controller", "--out", str(tmp_path)]) == 0
    assert main(["verify", str(tmp_path), "--model", str(model), "--vectors", "200"]) == 0
    assert "ok   ctl_mlp_controller_tick over" in capsys.readouterr().out
    c = tmp_path / "ctl_mlp_controller.c"
    c.write_text(
        re.sub(r"(ctl_mlp_pid = \{ )(\d+)", lambda m: m.group(1) + str(int(m.group(2)) * 2), c.read_text())
    )
    assert main(["verify", str(tmp_path), "--model", str(model), "--vectors", "200"]) == 1
    text = capsys.readouterr().out
    assert "ctl_mlp_controller.c: edited since export" in text
    assert re.search(r"FAIL ctl_mlp_controller_tick .*: tick \d+ .*C -?\d+ vs twin -?\d+ mV", text), text


def test_bare_network_export_verifies_without_step(tmp_path, capsys):
    """An export with NAME_infer only (inputs the pipeline does not compute) verifies: infer and oracle
    checks, no NAME_step check; on the M0+ core too."""
    import torch

    net = torch.nn.Sequential(torch.nn.Linear(3, 4), torch.nn.ReLU(), torch.nn.Linear(4, 1))
    torch.save(net, tmp_path / "net.pt")
    spec = tmp_path / "net.json"
    spec.write_text(json.dumps({"inputs": ["x0", "x1", "x2"], "input_range": [[0, 1], [-1, 1], [0, 10]]}))
    out = tmp_path / "fw"
    assert main(["export", str(tmp_path / "net.pt"), "--features", str(spec), "--out", str(out)]) == 0
    capsys.readouterr()
    for core in ("host", "cortex-m0plus"):
        if core != "host":
            pytest.importorskip("unicorn")
            from seagen.toolchain.cortexm import toolchain_missing

            if toolchain_missing():
                continue
        args = ["verify", str(out), "--model", str(tmp_path / "net.pt"), "--features", str(spec)]
        assert main([*args, "--vectors", "300", "--core", core]) == 0
        text = capsys.readouterr().out
        assert f"({core})" in text and "net_step" not in text and "agrees" in text


def test_reexport_without_controller_removes_its_files(tmp_path):
    """Re-exporting NAME without --controller removes the NAME_controller files an earlier export wrote."""
    model = str(default_model("mlp_control"))
    assert main(["export", model, "--prefix", "ctl_mlp", "--controller", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "ctl_mlp_controller.c").is_file()
    assert main(["export", model, "--prefix", "ctl_mlp", "--out", str(tmp_path)]) == 0
    assert (
        not (tmp_path / "ctl_mlp_controller.c").exists() and not (tmp_path / "ctl_mlp_controller.h").exists()
    )


def test_junit_to_a_bad_place_exits_2_before_checking(tmp_path):
    """--junit into /proc or onto a folder: exit 2, one line, before any check runs."""
    for bad in ("/proc/x/j.xml", str(tmp_path)):
        code, out, err = run("verify", str(GENERATED), "--model", str(CAL), "--junit", bad)
        assert code == 2 and "cannot write the JUnit report" in err and "Traceback" not in err and not out


@pytest.mark.parametrize("name", ["mlp_calibration", "mlp_control"])
def test_data_rows_and_recorded_trials(name, data_dir, capsys):
    """--data: NAME_step on the recorded test/validation trials and NAME_infer on their rows, bit for bit."""
    assert main(["verify", str(GENERATED), "--model", str(default_model(name)), "--data", str(data_dir)]) == 0
    text = capsys.readouterr().out
    for split in ("test", "validation"):
        assert re.search(rf"ok   \w+_step on {split} trials \(\d+ rows\)", text), text
        assert re.search(rf"ok   \w+_infer on {split} rows", text), text


def rehash(out: Path, name: str) -> None:
    """Recompute NAME's sha256 in the manifest (a tamper that hides an edit from the file hashes)."""
    from seagen.codegen.manifest import sha256_file

    man = out / "cal_mlp.seagen.json"
    doc = json.loads(man.read_text())
    doc["files"][name] = sha256_file(out / name)
    man.write_text(json.dumps(doc))


def edit(out: Path, name: str, old: str, new: str, count: int = 1, recompute: bool = False) -> None:
    """Replace text in one file of the export (the first `count` times), optionally hiding it by rehash."""
    text = (out / name).read_text()
    assert old in text, (name, old)
    (out / name).write_text(text.replace(old, new, count))
    if recompute:
        rehash(out, name)


def manifest_field(out: Path, change) -> None:
    """Apply `change` to the parsed manifest and write it back."""
    man = out / "cal_mlp.seagen.json"
    doc = json.loads(man.read_text())
    change(doc)
    man.write_text(json.dumps(doc))


def weight_edit(out: Path) -> None:
    """One weight of cal_mlp_w0 plus one."""
    c = (out / "cal_mlp.c").read_text()
    m = re.search(r"(cal_mlp_w0\[[^{]*\{\s*)(-?\d+)", c)
    assert m
    (out / "cal_mlp.c").write_text(c[: m.start(2)] + str(int(m.group(2)) + 1) + c[m.end(2) :])


def newline_style(out: Path, name: str, sep: str) -> None:
    """Rewrite a file's line ends (bytes as written, no newline translation)."""
    (out / name).write_bytes((out / name).read_bytes().replace(b"\n", sep.encode()))


# Every tamper `seagen verify` must catch: (id, edit of a fresh copy of generated/cal_mlp*, exit code,
# text the report (JSON on stdout, or the error line) must hold). Exit 0 rows are edits that keep the C.
TAMPERS = [
    ("weight edited", weight_edit, 1, "cal_mlp.c: edited since export"),
    (
        "weight edited, hash recomputed",
        lambda o: (weight_edit(o), rehash(o, "cal_mlp.c")),
        1,
        "C differs at row",
    ),
    (
        "header constant edited, hash recomputed",
        lambda o: edit(o, "cal_mlp.h", "#define CAL_MLP_OUT_Q 7", "#define CAL_MLP_OUT_Q 8", recompute=True),
        1,
        "cal_mlp.h: CAL_MLP_OUT_Q compiles to 8; the export's value is 7",
    ),
    (
        "header constant removed, hash recomputed",
        lambda o: edit(o, "cal_mlp.h", "#define CAL_MLP_IN_Q_POT 3", "", recompute=True),
        1,
        "CAL_MLP_IN_Q_POT compiles to not defined",
    ),
    (
        "error bound edited",
        lambda o: manifest_field(o, lambda d: d["resolved"].__setitem__("error_bound", 0.01)),
        1,
        "error_bound 0.01 (recomputed: 0.0698",
    ),
    (
        "output unit edited",
        lambda o: manifest_field(o, lambda d: d["resolved"].__setitem__("output", ["force_n", "kN"])),
        1,
        "resolved.output",
    ),
    (
        "file dropped from the manifest",
        lambda o: manifest_field(o, lambda d: d["files"].pop("cal_mlp.onnx")),
        1,
        "files omits cal_mlp.onnx",
    ),
    (
        "stray NAME_extra.c",
        lambda o: (o / "cal_mlp_extra.c").write_text("int cal_mlp_extra;\n"),
        1,
        "cal_mlp_extra.c: not part of the export in cal_mlp.seagen.json",
    ),
    ("file missing", lambda o: (o / "sea_fixed.h").unlink(), 1, "sea_fixed.h: missing"),
    (
        "prefix renamed in NAME.c, hash recomputed",
        lambda o: edit(o, "cal_mlp.c", "cal_mlp_infer", "foo_infer", count=-1, recompute=True),
        1,
        "the C does not build",
    ),
    (
        "NAME.onnx truncated, hash recomputed",
        lambda o: ((o / "cal_mlp.onnx").write_bytes(b"\x08\x07garbage"), rehash(o, "cal_mlp.onnx")),
        1,
        "cal_mlp.onnx: not a readable ONNX graph",
    ),
    (
        "manifest from a newer seagen",
        lambda o: manifest_field(o, lambda d: d.__setitem__("seagen_version", "9.0")),
        2,
        "written by seagen 9.0, newer than this seagen",
    ),
    ("unknown default model", lambda o: None, 2, "default:nope: no shipped model 'nope'"),
    (
        "manifest not JSON",
        lambda o: (o / "cal_mlp.seagen.json").write_text("{"),
        2,
        "not a readable seagen manifest",
    ),
    (
        "CRLF line ends",
        lambda o: [newline_style(o, n, "\r\n") for n in ("cal_mlp.c", "cal_mlp.h", "sea_nn.c")],
        0,
        "same C",
    ),
    (
        "reformatted (indent, blank lines, comment)",
        lambda o: (
            edit(o, "cal_mlp.c", "\n", "\n\n", count=5),
            edit(o, "cal_mlp.h", "#define CAL_MLP_OUT_Q 7", "#define   CAL_MLP_OUT_Q   7 /* Q */"),
            edit(o, "sea_fixed.c", "    ", "\t", count=-1),
        ),
        0,
        "cal_mlp.h: whitespace, comments or line ends differ from the export (same C)",
    ),
]


@pytest.mark.parametrize("tamper, code, message", [t[1:] for t in TAMPERS], ids=[t[0] for t in TAMPERS])
def test_tamper_table(tamper, code, message, tmp_path, capsys):
    """Each tamper: the exit code (1 behaviour, 2 bad input, 0 same C), the file named in the report, and
    JUnit XML plus JSON written with the outcome, whatever the exit code."""
    out = one_export(tmp_path)
    tamper(out)
    junit = tmp_path / "verify.xml"
    model = "default:nope" if "default:nope" in message else "default:mlp_calibration"
    got = main(["verify", str(out), "--model", model, "--vectors", "200", "--json", "--junit", str(junit)])
    stdout, stderr = capsys.readouterr()
    doc = json.loads(stdout)
    suite = ET.parse(junit).getroot()
    assert got == code, stdout + stderr
    assert doc["ok"] == (code == 0)
    assert message in stdout + stderr, stdout + stderr
    assert "Traceback" not in stdout + stderr and "seagen-cffi" not in stdout + stderr
    if code == 2:
        assert (
            message in doc["error"]
            and suite.get("errors") == "1"
            and suite.find("testcase/error") is not None
        )
    elif code == 1:
        assert int(suite.get("failures", "0")) >= 1
    else:
        assert suite.get("failures") == "0" and any(message in n for n in doc["notes"])


def test_junit_names_are_stable_and_skips_are_marked(tmp_path):
    """JUnit test names do not change with --vectors; checks not run after a drift are marked skipped."""
    out = one_export(tmp_path)
    names = []
    for n in ("100", "300"):
        report = tmp_path / f"v{n}.xml"
        assert main(["verify", str(out), "--model", str(CAL), "--vectors", n, "--junit", str(report)]) == 0
        names.append([c.get("name") for c in ET.parse(report).getroot().findall("testcase")])
    assert names[0] == names[1] and not any(re.search(r"\d{3}", n) for n in names[0]), names
    report = tmp_path / "other.xml"
    other = str(default_model("mlp_control"))
    assert main(["verify", str(out), "--model", other, "--junit", str(report)]) == 1
    cases = ET.parse(report).getroot().findall("testcase")
    skipped = [c.get("name") for c in cases if c.find("skipped") is not None]
    assert set(skipped) >= set(names[0]) - {c.get("name") for c in cases if c.find("skipped") is None}
    assert "quantization unchanged" in skipped and any("cal_mlp_infer" in n for n in skipped)


def test_target_and_core_are_the_same_option(capsys):
    """--target chooses where the C runs, as in export and bench; --core is kept as its alias."""
    for flag in ("--target", "--core"):
        args = ["verify", str(GENERATED), "--model", str(default_model("sf_calibration")), "--vectors", "50"]
        assert main([*args, flag, "host"]) == 0
        assert "(host)" in capsys.readouterr().out


def test_oracle_check_label_printed_once():
    """A data-row oracle check reads `ok   LABEL (counts): outcome`, its label not repeated in the outcome;
    a failing one names the first failure once too."""
    from seagen.reference.oracle import OracleReport
    from seagen.verify.result import Verdict
    from seagen.verify.run import add_oracle

    v = Verdict("cal_mlp", "fw")
    what = "C vs original on test rows (12080 of 12080 inside the box)"
    add_oracle(v, OracleReport(what, 12080, 0.00866, 0.196, 0.0123, "N"))
    add_oracle(v, OracleReport(what.replace("test", "validation"), 700, 0.5, 0.196, 0.0123, "N", "row 3"))
    lines = v.text().splitlines()
    assert lines[0].startswith("  ok   C vs original on test rows") and lines[0].count("C vs original") == 1
    assert "12080 inputs, max |integer - original| 0.00866 N <= bound 0.196 + margin 0.0123 N" in lines[0]
    assert lines[1].startswith("  FAIL C vs original on validation") and lines[1].count("C vs original") == 1
    assert "DISAGREES at row 3" in lines[1]


def test_data_of_another_actuator_is_refused(tmp_path, capsys):
    """--data recorded on another actuator than the model's: exit 2, one line naming its actuator.toml and
    both actuators (not a failure deep in the oracle)."""
    from seagen.actuator import load_actuator

    data = tmp_path / "data"
    data.mkdir()
    shutil.copy(EXAMPLE_ACTUATOR, data / "actuator.toml")
    assert main(["verify", str(one_export(tmp_path)), "--model", str(CAL), "--data", str(data)]) == 2
    err = capsys.readouterr().err.strip()
    digest = load_actuator(EXAMPLE_ACTUATOR).digest()[:12]
    assert "\n" not in err and str(data / "actuator.toml") in err and digest in err, err
