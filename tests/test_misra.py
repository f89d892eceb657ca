"""Exports under cppcheck 2.10's MISRA C:2012 addon: 0 findings outside seagen's deviation record."""

from __future__ import annotations

import pytest

from seagen.bench.glove import glove_files
from seagen.verify.misra import run_cppcheck, skip_reason, suppressions

pytestmark = pytest.mark.skipif(bool(skip_reason()), reason=skip_reason() or "")

GLOVE = (
    '#include "glove.h"',
    "static glove_t g;",
    "static const int32_t z[GLOVE_N_SEA] = {0};",
    "int16_t m[GLOVE_N_SEA];",
    "int16_t f[GLOVE_N_SEA];",
    "glove_init(&g, z, z);",
    "glove_tick(&g, z, z, z, m, f);",
)


@pytest.mark.parametrize("target", ["portable", "cortex-m4", "cortex-m0plus"])
def test_firmware_example_exports_clean(target):
    """examples/firmware's two exports (cal_mlp, ctl_mlp --controller) with the glove as caller."""
    found = run_cppcheck(glove_files(target), target, calls=GLOVE)
    assert not found, "\n".join(f.line_text() for f in found)


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


@pytest.mark.slow
@pytest.mark.parametrize("weights", ["int16", "int8"])
@pytest.mark.parametrize("target", ["portable", "cortex-m4", "cortex-m0plus"])
def test_option_matrix_clean(target, weights):
    """All four shipped models (SF and MLP, the control ones with --controller) in one folder."""
    from seagen.control.firmware import controller_files
    from seagen.defaults import GENERATED
    from seagen.export import prepare

    files = {}
    for m in ("sf_calibration", "mlp_calibration", "sf_control", "mlp_control"):
        e = prepare(str(GENERATED / "models" / f"{m}.pt"), prefix=m, target=target, weights=weights)
        files.update(e.files)
        if "control" in m:
            files.update(controller_files(m, e.qmodel))
    found = run_cppcheck({k: v for k, v in files.items() if k.endswith((".c", ".h"))}, target)
    assert not found, "\n".join(f.line_text() for f in found)
