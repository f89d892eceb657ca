"""seagen verify --prove: Frama-C Eva proves exports free of run-time errors; planted defects are caught."""

from __future__ import annotations

import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from seagen.defaults import GENERATED
from seagen.verify.prove import parse_alarms, prove_folder
from tests.conftest import run_cli

needs_frama_c = pytest.mark.skipif(shutil.which("frama-c") is None, reason="frama-c not installed")


def export(tmp: Path, model: str, target: str, weights: str = "int16", controller: bool = False) -> Path:
    """`seagen export default:MODEL` for TARGET into tmp/NAME, prefix m."""
    out = tmp / f"{model}-{target}-{weights}{'-ctl' if controller else ''}"
    args = ["export", f"default:{model}", "--target", target, "--weights", weights, "--out", str(out)]
    code, _out, err = run_cli(*args, "--prefix", "m", *(["--controller"] if controller else []))
    assert code == 0, err
    return out


def failures(v) -> str:
    """Every failed check's detail, one per line."""
    return "\n".join(f"{i.name}: {i.detail}" for i in v.items if not i.ok)


def line_of(path: Path, text: str) -> int:
    """The 1-based line of the only line of `path` containing `text`."""
    hits = [k + 1 for k, ln in enumerate(path.read_text().splitlines()) if text in ln]
    assert len(hits) == 1, (path, text, hits)
    return hits[0]


@needs_frama_c
def test_portable_default_export_proven():
    """generated/'s cal_mlp (the issue's first try: 10 alarms): 0 alarms for NAME_infer on every int16 input
    and NAME_step over 24 ticks from reset with any encoder count and any pot reading of the ADC."""
    v = prove_folder(GENERATED, "cal_mlp")
    assert v.ok, failures(v)
    assert [i.name.split(":")[0] for i in v.items] == ["cal_mlp_infer", "cal_mlp_step"]
    assert all("-machdep x86_64" in i.detail for i in v.items)


@needs_frama_c
@pytest.mark.slow
@pytest.mark.parametrize(
    ("model", "target", "controller"),
    [("sf_calibration", "cortex-m0plus", False), ("sf_control", "cortex-m4", True)],
)
def test_cortex_m_export_proven(tmp_path, model, target, controller):
    """One export per Cortex-M target, analysed as that core compiles it (32-bit machdep, its predefined
    macros; the M4's ACLE intrinsics as their contracts); the M4 one with its controller tick."""
    v = prove_folder(export(tmp_path, model, target, controller=controller))
    assert v.ok, failures(v)
    assert all("-machdep gcc_x86_32" in i.detail for i in v.items)
    assert any("controller_tick" in i.name for i in v.items) == controller


@needs_frama_c
def test_planted_unguarded_multiply_caught_with_its_line(tmp_path):
    """The int32 product enc * travel_q without its guard overflows for encoder counts the contract allows:
    Eva names sea_fixed.c at that line, and the JUnit case of NAME_step fails with file:line and property."""
    d = tmp_path / "fw"
    shutil.copytree(GENERATED, d, ignore=shutil.ignore_patterns("models", "*.onnx", "__init__.py"))
    src = d / "sea_fixed.c"
    text = src.read_text()
    guard = "if (SEA_ABS_BELOW(enc, a->enc_i32_bits)) {"
    assert text.count(guard) == 1
    src.write_text(text.replace(guard, "if (enc != 0) { /* planted: no guard */"))
    line = line_of(src, "travel = sea_rshift_rne_s32(enc * a->travel_q")
    v = prove_folder(d, "cal_sf")
    step = next(i for i in v.items if i.name.startswith("cal_sf_step"))
    assert not step.ok and f"sea_fixed.c:{line}: signed overflow" in step.detail, step.detail
    cases = ET.fromstring(v.junit()).findall("testcase")
    assert [c.get("name", "").split(":")[0] for c in cases] == ["cal_sf_infer", "cal_sf_step"]
    failure = cases[1].find("failure")
    assert failure is not None and f"sea_fixed.c:{line}: signed overflow" in (failure.text or "")


@needs_frama_c
@pytest.mark.slow
def test_planted_uninitialised_state_field_caught_with_its_line(tmp_path):
    """NAME_reset that leaves the state's `primed` flag unset: the first NAME_step reads it uninitialised
    (its precondition fails at the harness's call, named by line)."""
    d = tmp_path / "fw"
    shutil.copytree(GENERATED, d, ignore=shutil.ignore_patterns("models", "*.onnx", "__init__.py"))
    src = d / "sea_features.c"
    text = src.read_text()
    assert text.count("    s->primed = 0;\n") == 1
    src.write_text(text.replace("    s->primed = 0;\n", "    /* planted: primed left unset */\n"))
    v = prove_folder(d, "cal_sf")
    step = next(i for i in v.items if i.name.startswith("cal_sf_step"))
    assert not step.ok, failures(v)
    pre = r"cal_sf_eva_harness\.c:\d+: function cal_sf_step: precondition"
    assert re.search(pre, step.detail), step.detail
    assert next(i for i in v.items if i.name.startswith("cal_sf_infer")).ok


def test_parse_alarms_reads_file_line_and_property():
    """Eva's multi-line alarm messages become one file:line: property each, its temporaries' note dropped."""
    log = (
        "[eva] analysing\n[eva:alarm] /tmp/x/sea_fixed.c:33: Warning: \n  signed overflow.\n"
        "  assert -2147483648 ≤ v - (int32_t)(q * (int32_t)(1 << s));\n  (tmp from f(x))\n"
        "[eva:alarm] h.c:12: Warning: \n  function m_step: precondition got status invalid.\n[eva] done\n"
    )
    got = [a.text() for a in parse_alarms(log)]
    assert got == [
        "sea_fixed.c:33: signed overflow. assert -2147483648 ≤ v - (int32_t)(q * (int32_t)(1 << s));",
        "h.c:12: function m_step: precondition got status invalid.",
    ]


def test_verify_prove_without_frama_c_exits_2(tmp_path, monkeypatch):
    """No frama-c on PATH: one-line message, exit 2, the JUnit file carries the error."""
    monkeypatch.setenv("PATH", str(tmp_path))
    junit = tmp_path / "prove.xml"
    code, _out, err = run_cli(
        "verify", str(GENERATED), "--model", "default:sf_calibration", "--prove", "--junit", str(junit)
    )
    assert code == 2
    assert "frama-c not found" in err and len(err.strip().splitlines()) == 1, err
    assert ET.fromstring(junit.read_bytes()).find("testcase/error") is not None


@needs_frama_c
@pytest.mark.slow
def test_verify_prove_cli_writes_one_case_per_function(tmp_path):
    """`seagen verify --prove --junit` on a controller export: every check passes, and the JUnit report has
    one case per public function proven (infer, step, controller tick, and the tick on a shared pipeline)."""
    d = export(tmp_path, "sf_control", "portable", controller=True)
    junit = tmp_path / "v.xml"
    args = ["verify", str(d), "--model", "default:sf_control", "--vectors", "100", "--prove"]
    code, out, err = run_cli(*args, "--junit", str(junit))
    assert code == 0, out + err
    names = [c.get("name", "") for c in ET.fromstring(junit.read_bytes()).findall("testcase")]
    proven = [n.split(":")[0] for n in names if "Frama-C Eva" in n]
    assert proven[:3] == ["m_infer", "m_step", "m_controller_tick"], names
    assert proven[3:] == ["m_controller_tick on a shared pipeline"], names  # NAME_controller_init_shared


def matrix():
    """target x weights x SF/MLP x calibration/--controller (the Cortex-M4 int16 mlp_calibration, whose
    layer 0 packs signed clamped inputs two to a word, included: docs/prove.md)."""
    for target in ("portable", "cortex-m0plus", "cortex-m4"):
        for weights in ("int16", "int8"):
            for model in ("sf_calibration", "mlp_calibration", "sf_control", "mlp_control"):
                ctl = model.endswith("control")
                yield pytest.param(
                    model, target, weights, ctl, marks=pytest.mark.slow, id=f"{target}-{weights}-{model}"
                )


@needs_frama_c
@pytest.mark.slow
def test_m4_packed_inputs_without_their_clamp_caught(tmp_path):
    """The M4 int16 mlp_calibration's layer 0 with its pair clamps removed (packed inputs any int16, not the
    calibrated box): a layer-0 SMLAD sum then overflows int32 for real (a neuron's bias plus 32768 times its
    weights' magnitudes is 2.26e9 > 2^31), and Eva reports it at sea_smlad's line in sea_dsp.h: the halves Eva
    carries (sea_int16x2 as a struct) are the clamp's ranges, not an assumption that SMLAD cannot overflow."""
    d = export(tmp_path, "mlp_calibration", "cortex-m4")
    src = d / "m.c"
    text, n = re.subn(
        r"sea_clamp16x2\((sea_pack16x2\([^)]*\)), m_in_lo\[\d+\], m_in_hi\[\d+\]\)", r"\1", src.read_text()
    )
    assert n == 5
    src.write_text(text)
    line = line_of(d / "sea_dsp.h", "return __smlad(x, w, acc);")
    v = prove_folder(d)
    infer = next(i for i in v.items if i.name.startswith("m_infer"))
    assert not infer.ok and f"sea_dsp.h:{line}: signed overflow" in infer.detail, infer.detail


@needs_frama_c
@pytest.mark.parametrize(("model", "target", "weights", "controller"), list(matrix()))
def test_matrix_proven(tmp_path, model, target, weights, controller):
    """Every target x int16/int8 x SF/MLP x --controller export: 0 alarms for every public function."""
    v = prove_folder(export(tmp_path, model, target, weights, controller))
    assert v.ok, failures(v)


GLOVE_HARNESS = """#include "__fc_builtin.h"
#include "glove.h"

void prove_glove(void)
{
    glove_t g;
    int32_t enc[GLOVE_N_SEA];
    int32_t pot[GLOVE_N_SEA];
    int32_t force[GLOVE_N_SEA];
    int32_t mv[GLOVE_N_SEA];
    int16_t est[GLOVE_N_SEA];
    int k;
    int t;
    for (k = 0; k < GLOVE_N_SEA; ++k) {
        enc[k] = Frama_C_interval(CTL_MLP_ENC_MIN, CTL_MLP_ENC_MAX);
        pot[k] = Frama_C_interval(CTL_MLP_POT_MIN, CTL_MLP_POT_MAX);
    }
    glove_init(&g, enc, pot);
    /*@ loop unroll 12; */
    for (t = 0; t < 12; ++t) {
        for (k = 0; k < GLOVE_N_SEA; ++k) {
            enc[k] = Frama_C_interval(CTL_MLP_ENC_MIN, CTL_MLP_ENC_MAX);
            pot[k] = Frama_C_interval(CTL_MLP_POT_MIN, CTL_MLP_POT_MAX);
            force[k] = Frama_C_interval(CTL_MLP_FORCE_MIN, CTL_MLP_FORCE_MAX);
        }
        glove_tick(&g, enc, pot, force, mv, est);
    }
}
"""


@needs_frama_c
@pytest.mark.slow
@pytest.mark.parametrize("target", ["portable", "cortex-m0plus", "cortex-m4"])
def test_firmware_example_as_caller_proven(target):
    """examples/firmware's glove (seven actuators, cal_mlp and ctl_mlp --controller on one shared pipeline
    each) as the caller: 12 ticks from glove_init with every sensor over the contracts' domain, 0 alarms."""
    from seagen.bench.glove import glove_files
    from seagen.codegen.render import environment
    from seagen.verify.prove import prove_sources

    files = {n: s for n, s in glove_files(target).items() if n.endswith((".c", ".h")) and "/" not in n}
    files["glove_eva_harness.c"] = GLOVE_HARNESS
    if target == "cortex-m4":
        files["arm_acle.h"] = environment().get_template("eva_arm_acle.h.j2").render({})
    alarms, failed = prove_sources(files, target, ["prove_glove"])["prove_glove"]
    assert not failed and not alarms, failed or "\n".join(a.text() for a in alarms)
