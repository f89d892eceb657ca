"""`seagen bench` and `seagen export --target`: the cycle model, the ISA check, the helper classification,
one small export measured end to end (about 10 s with -n 2), and the controller tick and run of an export
for another design (its description's controller, its counts and ticks)."""

from __future__ import annotations

import json
import re
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from seagen.actuator import Actuator, actuator_from_dict, default_actuator, load_actuator, to_toml
from seagen.bench import tick as T
from seagen.bench.run import FLOAT_HELPER, N_CALLS
from seagen.cli import main
from seagen.defaults import GENERATED
from seagen.modelfile import load_model, save_model
from seagen.runtime.actq import act_q
from seagen.runtime.control import MLP_PRED_AVG, ControlConfig, control_reset, control_step, q16
from seagen.runtime.pid import DEFAULT_PID
from seagen.toolchain.mcu_trace import Insn, cycles, isa_violation
from tests.conftest import EXAMPLE_ACTUATOR, run_cli


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


PID = ("kp", "ki", "kd", "d_alpha", "margin", "out_min", "out_max")
SLOW = Path(__file__).with_name("slow_6v.toml")


def design_12v() -> Actuator:
    """The example's stiff 24 V design (200 Hz loop, 8.4 N/mm, 65,536 counts a turn) with a 12 V limit."""
    d = tomllib.loads(EXAMPLE_ACTUATOR.read_text())
    d["name"] = "stiff 24 V, 12 V limit"
    d["control"]["limit_v"] = 12.0
    return actuator_from_dict(d, "stiff_12v")


@pytest.fixture(scope="module")
def design_export(tmp_path_factory):
    """The default control models recorded for design_12v, exported with --controller (one folder)."""
    from seagen.export import prepare, write

    d = tmp_path_factory.mktemp("design_12v")
    act = design_12v()
    (d / "design.toml").write_text(to_toml(act))
    for name, prefix in (("sf_control", "ctl_sf"), ("mlp_control", "ctl_mlp")):
        save_model({**load_model(GENERATED / "models" / f"{name}.pt"), "actuator": act.record()}, d / name)
        write(prepare(str(d / name), prefix=prefix, controller=True), d / "fw")
    return d


def settings(text: str, obj: str) -> dict[str, int]:
    """The `obj.field = integer;` assignments of a C text, by field."""
    return {k: int(v) for k, v in re.findall(rf"{re.escape(obj)}\.([\w.]+) = (-?\d+);", text)}


@pytest.mark.parametrize("prefix", ["ctl_sf", "ctl_mlp"])
def test_tick_driver_is_the_exports_controller_on_another_design(design_export, prefix):
    """On a design with a 12 V limit and a 200 Hz loop, the bench's tick driver sets what the export's own
    NAME_controller.c sets (its pid table and fields; the encoder-jump and stuck-pot bounds it reads from
    NAME_ACT): the design's +-12,000 mV and its loop's gains (ki per tick half, kd double the paper's
    100 Hz ones), never the paper's 6,500 mV."""
    fw, act = design_export / "fw", design_12v()
    got = T.export_actuator(fw, prefix, act)
    driver = T.tick_driver(prefix, T.controller_config((fw / f"{prefix}.h").read_text(), prefix, got))
    mine = settings(driver[f"{prefix}_bench.c"], "w->cfg")
    ctl = (fw / f"{prefix}_controller.c").read_text()
    table = re.search(rf"sea_pid_params {prefix}_pid = \{{([^}}]*)\}}", ctl)
    assert table is not None
    theirs = {f"pid.{n}": int(v) for n, v in zip(PID, table.group(1).split(","), strict=True)}
    theirs.update(settings(ctl, "a->config"))
    assert mine == {k: v for k, v in theirs.items() if k in mine}
    aq = act_q(act)
    assert (theirs["enc_jump_max"], theirs["pot_stuck_ticks"]) == (aq.enc_jump_max, aq.pot_stuck_ticks)
    assert f"{prefix.upper()}_ACT->enc_jump_max" in driver[f"{prefix}_bench.c"]
    assert (mine["pid.out_min"], mine["pid.out_max"]) == (-12000, 12000)
    assert "6500" not in driver[f"{prefix}_bench.c"]
    paper = DEFAULT_PID
    assert abs(2 * mine["pid.ki"] - paper.ki) <= 1 and abs(mine["pid.kd"] - 2 * paper.kd) <= 2
    assert mine["pred_avg"] == (MLP_PRED_AVG if prefix == "ctl_mlp" else 1)


def no_fault(act: Actuator, run: T.Run) -> bool:
    """Whether the controller twin of `act` ticks along the run without latching a fault."""
    cfg = ControlConfig.for_act(act_q(act))
    s = control_reset(cfg, run.enc[:1], run.pot[:1])
    for k in range(len(run.enc)):
        s = control_step(cfg, s, run.enc[k : k + 1], run.pot[k : k + 1], np.array([run.force_q16]))
    return bool(s.fault[0] == 0)


def test_run_spans_the_designs_counts_at_its_loop_rate():
    """The bench's run on design_12v: a push of its compression range at 20 N in its own counts (20 N /
    8.4 N/mm over 4 mm per 16 x 4,096 counts, times the paper's 1,500 / 1,086), 0.4 s of its 200 Hz ticks
    (40 of them traced), 40 % of its force range desired; not the paper's 1,500 counts; no fault."""
    act, paper = design_12v(), default_actuator()

    def counts(a: Actuator) -> float:
        return (
            a.control.force_max_n
            / a.stiffness_n_per_mm
            * a.motor.gear_ratio
            * a.motor.counts_per_rev
            / a.lead_mm
        )

    run = T.run_of(act, N_CALLS)
    assert abs(run.enc.max() - 1500 * counts(act) / counts(paper)) <= 1 and run.enc.min() == 0
    assert run.enc.max() > 30 * 1500 and 1500 not in run.enc
    assert (len(run.enc), run.every, run.force_q16) == (80, 2, q16(0.4 * act.control.force_max_n))
    assert no_fault(act, run)


def test_run_on_the_paper_is_its_old_run():
    """On the paper's actuator the run is exactly the one its bench figures were measured on: 1,500 counts
    in 40 ticks, the pot at 1,800 +- 40 + 3 counts, 8 N desired, every tick traced."""
    run = T.run_of(default_actuator(), N_CALLS)
    k = np.arange(40)
    assert np.array_equal(run.enc, np.rint(1500 * np.sin(np.pi * k / 40) ** 2))
    assert np.array_equal(run.pot, np.rint(1800 + 40 * np.sin(k / 7.0) + 3 * np.cos(k * 1.7)))
    assert (run.force_q16, run.every) == (8 << 16, 1)
    assert no_fault(default_actuator(), run)


@pytest.mark.slow  # ~4 s: 5,209 ticks of the slow design's push
def test_run_of_a_slow_drive_stays_within_its_encoder_jump_bound():
    """tests/slow_6v.toml (51 counts per tick at most, 60,000 counts of compression range): the push takes
    more than 0.4 s of ticks so that no step trips the encoder-jump fault; still 40 traced ticks."""
    act = load_actuator(SLOW)
    run = T.run_of(act, N_CALLS)
    assert len(run.enc) > 0.4 * act.loop_hz and np.abs(np.diff(run.enc)).max() <= act_q(act).enc_jump_max
    assert len(range(0, len(run.enc), run.every)) <= N_CALLS and run.enc.max() > 30 * 1500
    assert no_fault(act, run)


def test_bench_of_another_designs_export_needs_its_description(design_export):
    """An export for design_12v: without --actuator (or with another design's) exit 2 naming the export's
    actuator, before anything is built."""
    fw = str(design_export / "fw")
    code, _, err = run_cli("bench", fw)
    assert code == 2 and "'stiff 24 V, 12 V limit'" in err and "--actuator" in err
    code, _, err = run_cli("bench", fw, "--actuator", str(SLOW))
    assert code == 2 and "'slow 6 V SEA (seagen test design)'" in err


@pytest.mark.slow  # ~6 s on the emulated core; the fast tests check the driver's settings and run in Python
def test_bench_cli_measures_another_designs_tick(design_export):
    """`seagen bench --actuator` on design_12v's SF export: the tick is measured (M0+), no float helper."""
    pytest.importorskip("unicorn", reason="unicorn (seagen[mcu]) is not installed")
    from seagen.toolchain.cortexm import toolchain_missing

    if msg := toolchain_missing():
        pytest.skip(msg)
    fw = design_export / "sf_only"  # the package without the MLP export (its sub-folders too)
    shutil.copytree(design_export / "fw", fw, ignore=shutil.ignore_patterns("ctl_mlp*"))
    args = ("bench", str(fw), "--target", "cortex-m0plus", "--json", "--actuator")
    code, out, _ = run_cli(*args, str(design_export / "design.toml"))
    rows = json.loads(out)
    assert code == 0 and [r["entry"] for r in rows] == ["ctl_sf_infer", "ctl_sf_step", "ctl_sf_bench_tick"]
    assert rows[-1]["instr_min"] > 0 and rows[-1]["float_helpers"] == []
