"""Exports under cppcheck 2.10's MISRA C:2012 addon: 0 findings outside seagen's deviation record."""

from __future__ import annotations

import pytest

from seagen.bench.glove import glove_files
from seagen.verify.misra import run_cppcheck, skip_reason, suppressions

needs_cppcheck = pytest.mark.skipif(bool(skip_reason()), reason=skip_reason() or "")

GLOVE = (
    '#include "glove.h"',
    "static glove_t g;",
    "static const int32_t z[GLOVE_N_SEA] = {0};",
    "int16_t m[GLOVE_N_SEA];",
    "int16_t f[GLOVE_N_SEA];",
    "glove_init(&g, z, z);",
    "glove_tick(&g, z, z, z, m, f);",
)


@needs_cppcheck
@pytest.mark.parametrize(
    "target",
    [
        "portable",
        pytest.param("cortex-m4", marks=pytest.mark.slow),
        pytest.param("cortex-m0plus", marks=pytest.mark.slow),
    ],
)
def test_firmware_example_exports_clean(target):
    """examples/firmware's two exports (cal_mlp, ctl_mlp --controller) with the glove as caller."""
    found = run_cppcheck(glove_files(target), target, calls=GLOVE)
    assert not found, "\n".join(f.line_text() for f in found)


@needs_cppcheck
def test_one_export_alone_clean():
    """A folder holding one portable export without the controller (the runtime files it ships, no more)."""
    from seagen.defaults import GENERATED
    from seagen.export import prepare

    ex = prepare(str(GENERATED / "models" / "sf_calibration.pt"), prefix="cal_sf")
    found = run_cppcheck({k: v for k, v in ex.files.items() if k.endswith((".c", ".h"))}, "portable")
    assert not found, "\n".join(f.line_text() for f in found)


@needs_cppcheck
def test_added_finding_and_suppression_comment_fail():
    """A finding added by editing the C fails, and a suppression comment does not hide it."""
    files = glove_files("portable")
    files["cal_mlp.c"] += (
        "\n/* cppcheck-suppress misra-c2012-12.1 */\nint32_t cal_mlp_extra(int32_t a, int32_t b)\n"
    )
    files["cal_mlp.c"] += "{\n    return a + b * 2 - a;\n}\n"
    rules = {f.rule for f in run_cppcheck(files, "portable", calls=GLOVE)}
    assert "suppression-comment" in rules
    assert rules - {"suppression-comment"}, rules


@needs_cppcheck
def test_record_never_suppresses_everything():
    """Every deviation names its lines: no entry covers a whole file or every line of a rule."""
    files = glove_files("cortex-m0plus")
    lines = suppressions(files)
    per_file = {}
    for s in lines:
        rule, name, _ = s.rsplit(":", 2)
        per_file.setdefault((rule, name), 0)
        per_file[(rule, name)] += 1
    for (rule, name), n in per_file.items():
        assert n < len(files[name].splitlines()) // 2, (rule, name)


@needs_cppcheck
@pytest.mark.slow
@pytest.mark.parametrize("weights", ["int16", "int8"])
@pytest.mark.parametrize("target", ["portable", "cortex-m4", "cortex-m0plus"])
def test_option_matrix_clean(target, weights):
    """All four shipped models (SF and MLP, the control ones with --controller) in one folder, and each
    export alone (the control ones also without --controller)."""
    from seagen.codegen.controller import controller_files
    from seagen.defaults import GENERATED
    from seagen.export import prepare

    files, alone = {}, {}
    for m in ("sf_calibration", "mlp_calibration", "sf_control", "mlp_control"):
        e = prepare(str(GENERATED / "models" / f"{m}.pt"), prefix=m, target=target, weights=weights)
        alone[m] = {**e.files, **(controller_files(m, e.qmodel) if "control" in m else {})}
        if "control" in m:
            alone[f"{m} without --controller"] = e.files
        files.update(alone[m])
    found = run_cppcheck({k: v for k, v in files.items() if k.endswith((".c", ".h"))}, target)
    assert not found, "\n".join(f.line_text() for f in found)
    for m, ex in alone.items():  # each export alone in its folder: the runtime files it ships, no more
        found = run_cppcheck({k: v for k, v in ex.items() if k.endswith((".c", ".h"))}, target)
        assert not found, m + ":\n" + "\n".join(f.line_text() for f in found)


@needs_cppcheck
@pytest.mark.slow
@pytest.mark.parametrize("target", ["portable", "cortex-m4", "cortex-m0plus"])
def test_odd_sizes_and_wide_accumulators_clean(target):
    """tests/test_target_kernels.py's odd widths, one-layer nets and 64-bit accumulators, each alone."""
    from seagen.codegen.render import RUNTIME, render
    from seagen.codegen.runtime import runtime_sources
    from seagen.codegen.targets import OMIT
    from seagen.codegen.targets import RUNTIME as EXTRA
    from tests.test_target_kernels import SMALL, _odd_mlp, quantize_mlp

    runtime = runtime_sources(*[n for n in RUNTIME if n not in OMIT[target]], *EXTRA[target])
    for k, case in enumerate(SMALL):
        files = {**render(quantize_mlp(_odd_mlp(*case)), f"odd{k}", target), **runtime}
        found = run_cppcheck(files, target)
        assert not found, f"{case}:\n" + "\n".join(f.line_text() for f in found)


def _export(tmp_path, target: str = "cortex-m4"):
    """The control MLP exported with --controller for `target` into a fresh folder (the CLI)."""
    from seagen.cli import main
    from seagen.defaults import default_model

    out, model = tmp_path / "fw", default_model("mlp_control")
    args = ["export", str(model), "--prefix", "ctl", "--controller", "--target", target, "--out", str(out)]
    assert main(args) == 0
    return out, model


def _misra_item(verdict):
    """The MISRA check of a verdict."""
    return next(i for i in verdict.items if i.name.startswith("MISRA C:2012"))


@needs_cppcheck
def test_verify_misra_passes_then_fails_on_an_edit(tmp_path, capsys):
    """verify --misra on a committed export: passes and is reported in JUnit; a finding added by hand
    (with a suppression comment) fails it."""
    import xml.etree.ElementTree as ET

    from seagen.cli import main
    from seagen.verify.run import verify

    out, model = _export(tmp_path)
    junit = tmp_path / "r.xml"
    args = ["verify", str(out), "--model", str(model), "--vectors", "50", "--misra", "--junit", str(junit)]
    assert main(args) == 0
    cases = [c for c in ET.parse(junit).getroot().iter("testcase") if c.get("name", "").startswith("MISRA")]
    assert len(cases) == 1 and not cases[0].findall("failure") and not cases[0].findall("skipped")
    c = out / "ctl.c"
    c.write_text(
        c.read_text()
        + "\n/* cppcheck-suppress misra-c2012-12.1 */\nint32_t ctl_x(int32_t a) { return a + a * 2; }\n"
    )
    item = _misra_item(verify(str(out), str(model), vectors=0, misra=True))
    assert not item.ok and "suppression-comment" in item.detail and "8.4" in item.detail
    capsys.readouterr()


def test_verify_misra_skipped_without_cppcheck_210(tmp_path, monkeypatch):
    """Another cppcheck version (or none): the check is marked skipped with the reason, in JUnit too."""
    import seagen.verify.misra as M
    from seagen.verify.run import verify

    out, model = _export(tmp_path, "portable")
    monkeypatch.setattr(
        M, "skip_reason", lambda exe="cppcheck": "cppcheck 2.13 installed; the record is 2.10's"
    )
    v = verify(str(out), str(model), vectors=0, misra=True)
    item = _misra_item(v)
    assert item.ok and item.skipped and item.kind == "misra" and "2.13" in item.detail
    assert b"<skipped" in v.junit()


def test_record_documented():
    """Every deviation of the record has its section in docs/misra.md."""
    from pathlib import Path

    from seagen.verify.misra_record import RECORD

    doc = (Path(__file__).resolve().parents[1] / "docs" / "misra.md").read_text()
    for ident in sorted({d.ident for d in RECORD}):
        assert f"### {ident} " in doc, ident
