"""`seagen bench` and `seagen export --target`: the cycle model, the ISA check, the helper classification, and
one small export measured end to end (about 10 s with -n 2)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from seagen.bench.run import FLOAT_HELPER
from seagen.cli import main
from seagen.defaults import GENERATED
from seagen.toolchain.mcu_trace import Insn, cycles, isa_violation


def test_cycle_model_follows_the_documented_table():
    """Loads 2 (M4: 1 when pipelined), taken branches 2 on the M0+ and 3 on the M4, POP {.., pc} 1 + N + 2."""
    ldr, b, pop = Insn("ldr", 2, "r0, [r1]"), Insn("bne", 2, "8"), Insn("pop", 2, "{r4, r5, pc}")
    assert cycles("cortex-m0plus", ldr, False, True) == 2
    assert cycles("cortex-m4", ldr, False, True) == 1
    assert cycles("cortex-m4", ldr, False, False) == 2
    assert (cycles("cortex-m0plus", b, True, False), cycles("cortex-m0plus", b, False, False)) == (2, 1)
    assert cycles("cortex-m4", b, True, False) == 3
    assert cycles("cortex-m0plus", pop, True, False) == 1 + 3 + 2
    assert cycles("cortex-m0plus", Insn("muls", 2, ""), False, False) == 1  # single-cycle multiplier


def test_isa_check_rejects_thumb2_and_dsp_on_m0plus():
    """ARMv6-M: 16-bit Thumb plus BL/DMB/DSB/ISB/MRS/MSR; SMLAD, IT and 32-bit LDR.W are not on an M0+."""
    ok = [Insn("adds", 2, ""), Insn("bl", 4, ""), Insn("ldrh", 2, ""), Insn("beq", 2, "")]
    bad = [Insn("smlad", 4, ""), Insn("ldr", 4, ""), Insn("it", 2, ""), Insn("mul", 4, "")]
    assert all(isa_violation("cortex-m0plus", i) is None for i in ok)
    assert all(isa_violation("cortex-m0plus", i) is not None for i in bad)
    assert isa_violation("cortex-m4", Insn("smlad", 4, "")) is None
    assert isa_violation("cortex-m4", Insn("vadd", 4, "")) is not None  # no FPU use in integer kernels


def test_float_helpers_are_told_from_integer_helpers():
    """Soft-float helpers (AEABI and GCC names) match; libgcc's integer helpers do not."""
    assert all(FLOAT_HELPER.match(n) for n in ("__aeabi_fadd", "__aeabi_i2f", "__aeabi_dmul", "__addsf3"))
    assert not any(FLOAT_HELPER.match(n) for n in ("__aeabi_ldivmod", "__aeabi_lmul", "__divdi3", "__clzsi2"))


@pytest.fixture(scope="module")
def small_export(tmp_path_factory):
    """The default SF control predictor exported for the M0+ (small: fast to build and emulate)."""
    pytest.importorskip("unicorn", reason="unicorn (seagen[mcu]) is not installed")
    from seagen.toolchain.cortexm import toolchain_missing

    if msg := toolchain_missing():
        pytest.skip(msg)
    d = tmp_path_factory.mktemp("ctl_sf_m0")
    model = str(GENERATED / "models" / "sf_control.pt")
    assert main(["export", model, "--prefix", "ctl_sf", "--target", "cortex-m0plus", "--out", str(d)]) == 0
    return d


def test_export_target_writes_its_kernel(small_export):
    """--target cortex-m0plus ships sea_dsp.h and a straight-line Horner kernel in NAME.c."""
    assert (small_export / "sea_dsp.h").exists()
    assert "sea_mulshr_s32(" in (small_export / "ctl_sf.c").read_text()


def test_bench_cli_measures_every_entry_point(small_export, capsys):
    """infer, step and the controller tick are measured; no float helper, no foreign instruction, and the
    static stack bound covers the deepest stack measured."""
    assert main(["bench", str(small_export), "--target", "cortex-m0plus", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["entry"] for r in rows] == ["ctl_sf_infer", "ctl_sf_step", "ctl_sf_bench_tick"]
    for r in rows:
        assert r["float_helpers"] == [] and r["isa_violations"] == []
        assert 0 < r["instr_min"] <= r["instr_mean"] <= r["instr_max"] < r["cycles_mean"] * 2
        assert r["stack_static"] is not None and r["stack_static"] >= r["stack_measured"] > 0
        assert r["flash"] > 0 and r["ram"] == 0


def test_bench_of_a_folder_without_models_is_a_clear_error(tmp_path, capsys):
    """A folder with no NAME.h declaring NAME_infer: exit 2 and one line naming it."""
    assert main(["bench", str(tmp_path)]) == 2
    assert "no exported model" in capsys.readouterr().err


def test_box_read_from_every_target_is_the_same():
    """seagen bench reads the input box from NAME.c: int16 tables, or the M4 kernel's packed int16 pairs (an
    odd input count padded), the same values either way."""
    from seagen.bench.run import _box
    from seagen.export import prepare

    model = str(GENERATED / "models" / "mlp_calibration.pt")
    boxes = []
    for target in ("portable", "cortex-m4", "cortex-m0plus"):
        f = prepare(model, prefix="cal_mlp", target=target).files
        boxes.append(_box(f["cal_mlp.c"], "cal_mlp", f["cal_mlp.h"]))
    assert len(boxes[0][0]) == 9 and all(np.array_equal(b[k], boxes[0][k]) for b in boxes for k in (0, 1))
