"""Processor in the loop: the firmware of seagen/pil on QEMU boards (mps2-an386 Cortex-M4, microbit Cortex-M0)
closes the force loop with the plant bit-identical to the Python twins; a broken link is one clear error."""

from __future__ import annotations

import json
import os
import signal

import numpy as np
import pytest

from seagen.cli import main
from seagen.codegen.controller import controller_files, shipped_config
from seagen.codegen.runtime import runtime_sources
from seagen.control.gentwin import StepTwin
from seagen.defaults import GENERATED
from seagen.errors import UserError
from seagen.export import prepare
from seagen.pil import link as link_mod
from seagen.pil.controller import PilController
from seagen.pil.link import qemu_missing
from seagen.runtime.control import ControlConfig, sensor_walk
from seagen.setups.shipped import export as default_ir
from seagen.toolchain.controller import generated_sources
from seagen.toolchain.cortexm import toolchain_missing
from seagen.verify.pil import closed_loop
from tests.conftest import EXAMPLE_ACTUATOR

CORES = ("cortex-m4", "cortex-m0plus")
ANGLES = np.array([8.0, 16.0, 24.0])


@pytest.fixture(scope="module", autouse=True)
def tools():
    """Skip (with the reason) where the cross compiler or QEMU is missing."""
    if msg := toolchain_missing() or qemu_missing("qemu-system-arm"):
        pytest.skip(msg)


@pytest.fixture(scope="module")
def cal_qm():
    """The quantized IR of the default calibration MLP (generated/cal_mlp.c is its export)."""
    return prepare(str(GENERATED / "models" / "mlp_calibration.pt"), prefix="cal_mlp").qmodel


def fw_files(ctl: str = "ctl_sf") -> dict[str, str]:
    """The control export with its controller and the calibration export, as one folder holds them."""
    files = {**runtime_sources("sea_fixed.h", "sea_fixed.c"), **generated_sources(ctl, GENERATED)}
    files.update(controller_files(ctl, default_ir(ctl).qmodel))
    return {**files, **generated_sources("cal_mlp", GENERATED)}


def twin_cfg(ctl: str = "ctl_sf") -> ControlConfig:
    """The shipped controller configuration with the predictor's per-tick twin."""
    qm = default_ir(ctl).qmodel
    return ControlConfig(**{**shipped_config(qm).__dict__, "predictor": StepTwin(ctl, qm)})


@pytest.mark.parametrize(("core", "shared"), [(c, True) for c in CORES] + [("cortex-m0plus", False)])
def test_closed_loop_bit_identical(core, shared, cal_qm):
    """Every tick's command, controller state and calibrated force estimate from the board equals the twins'
    (each model with its own pipeline) over a short closed-loop run at three contact angles (the plant sees
    the board's commands); the firmware runs one feature pipeline per actuator for both models, or (not
    shared) one per model."""
    board = PilController(fw_files(), "ctl_sf", core, "cal_mlp", shared=shared)
    try:
        problem, done = closed_loop(board, twin_cfg(), cal_qm, ANGLES, 10.0, 60, seed=1)
    finally:
        board.close()
    assert problem is None, problem
    assert done == 60 and len(board.instructions) == 60


def _unicorn_ticks(core: str, enc, pot, force, tmp) -> np.ndarray:
    """Instructions of one actuator's tick (the shared feature pipeline, cal_mlp_step_features and
    ctl_sf_controller_tick, as the firmware runs them) traced on unicorn (with the M4's IT-skipped
    instructions, seagen/toolchain/mcu_trace.py)."""
    probe = (
        '#include "ctl_sf_controller.h"\n#include "cal_mlp.h"\n'
        "typedef struct { ctl_sf_controller_t c; sea_features_state s; sea_features_out f; } probe_t;\n"
        "void probe_init(probe_t *p, int32_t e, int32_t q);\n"
        "void probe_init(probe_t *p, int32_t e, int32_t q)\n"
        "{ sea_features_reset(&p->s); ctl_sf_controller_init_shared(&p->c, e, q, &p->f); }\n"
        "int32_t probe_tick(probe_t *p, int32_t e, int32_t q, int32_t f, int16_t *est);\n"
        "int32_t probe_tick(probe_t *p, int32_t e, int32_t q, int32_t f, int16_t *est)\n"
        "{ sea_features_step(&p->s, CAL_MLP_ACT, e, q, &p->f); *est = cal_mlp_step_features(&p->f);\n"
        "  return ctl_sf_controller_tick(&p->c, e, q, f); }\n"
    )
    from seagen.bench.run import _machine
    from seagen.toolchain import cortexm as cm
    from seagen.toolchain.host import compile_objects
    from seagen.toolchain.mcu_trace import disassemble, traced_call

    flags = cm.cpu_flags(core)
    srcs = {**fw_files(), "probe.c": probe}
    objs = compile_objects(srcs, tmp, (*flags, *cm.FREESTANDING), cc=cm.GCC, pic=False)
    (tmp / "link.ld").write_text(cm.LINKER_SCRIPT)
    elf = cm.link(tmp, objs, flags, ("probe_init", "probe_tick"), "probe")
    m, code = _machine(elf, core), disassemble(elf)
    st = m.call("probe_init", np.zeros(2048, np.uint8), int(enc[0]), int(pot[0]))[0][0]
    counts = []
    for e, q, f in zip(enc, pot, force, strict=True):
        back, t = traced_call(m, code, "probe_tick", st, int(e), int(q), int(f), np.zeros(1, np.int16))
        st = back[0]
        counts.append(t.instructions)
    return np.array(counts)


@pytest.mark.parametrize("core", CORES)
def test_instruction_count_matches_unicorn(core, tmp_path):
    """The firmware's own count per tick (SysTick under -icount, frame handling excluded) is within 0.5 % of
    the unicorn trace of the same calls (both count the M4's instructions skipped inside IT blocks)."""
    enc, pot, force = sensor_walk(5, 15, start=(300, 1200))
    board = PilController(fw_files(), "ctl_sf", core, "cal_mlp")
    try:
        board.reset(enc[:1], pot[:1])
        for k in range(15):
            board.step(enc[k : k + 1], pot[k : k + 1], force[k : k + 1])
    finally:
        board.close()
    pil = np.mean(board.instructions)
    uni = np.mean(_unicorn_ticks(core, enc, pot, force, tmp_path))
    tol = 0.005
    print(f"{core}: firmware {pil:.1f}, unicorn {uni:.1f} instructions per tick ({pil / uni - 1:+.2%})")
    assert abs(pil - uni) <= tol * uni, (pil, uni)


def test_corrupted_frame_is_rejected(monkeypatch):
    """A frame corrupted on the way to the board fails the firmware's Fletcher check: one clear error."""
    board = PilController(fw_files(), "ctl_sf", "cortex-m4", "cal_mlp")
    try:
        board.reset(np.array([300]), np.array([1200]))
        good = link_mod.frame

        def flip(kind, n, seq, payload):
            out = bytearray(good(kind, n, seq, payload))
            if kind == "T":
                out[6] ^= 0x10
            return bytes(out)

        monkeypatch.setattr(link_mod, "frame", flip)
        with pytest.raises(UserError, match="rejected frame .*failed its check"):
            board.step(np.array([300]), np.array([1200]), np.array([655360]))
    finally:
        board.close()


def test_corrupted_reply_is_named(monkeypatch):
    """A reply corrupted on the way back fails the host's Fletcher check: one clear error."""
    board = PilController(fw_files(), "ctl_sf", "cortex-m0plus", "cal_mlp")
    try:
        board.reset(np.array([300]), np.array([1200]))
        assert board.link is not None
        read = board.link._read

        def flip(n: int, what: str) -> bytes:
            out = bytearray(read(n, what))
            if n > 4:  # the reply's body
                out[3] ^= 0x01
            return bytes(out)

        monkeypatch.setattr(board.link, "_read", flip)
        with pytest.raises(UserError, match="corrupted frame from the board"):
            board.step(np.array([300]), np.array([1200]), np.array([655360]))
    finally:
        board.close()


@pytest.mark.parametrize("fault", ["silent", "crash"])
def test_board_fault_is_one_clear_error(fault):
    """A guest that stops answering times out; a QEMU that dies is named with its exit status."""
    board = PilController(fw_files(), "ctl_sf", "cortex-m0plus", "cal_mlp")
    board.timeout_s = 0.5
    try:
        board.reset(np.array([300]), np.array([1200]))
        assert board.link is not None
        os.kill(board.link.proc.pid, signal.SIGSTOP if fault == "silent" else signal.SIGKILL)
        want = "no answer from the board within 0.5 s" if fault == "silent" else "QEMU exit status -9"
        with pytest.raises(UserError, match=want):
            board.step(np.array([300]), np.array([1200]), np.array([655360]))
    finally:
        board.close()
    assert board.link is None


def test_qemu_missing_exits_2(monkeypatch, capsys):
    """Without the emulator, simulate --impl pil exits 2 with one line saying how to install it."""
    monkeypatch.setenv("SEAGEN_QEMU", "/nonexistent/qemu-system-arm")
    assert main(["simulate", "--impl", "pil", "--config", "sf_mcu"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "apt-get install qemu-system-arm" in err[0]


def test_cli_pil_agrees(tmp_path, capsys):
    """seagen pil on an export folder (control SF + its controller, calibration MLP): exit 0, JSON and JUnit
    with the firmware's instruction count."""

    models = GENERATED / "models"
    assert (
        main(
            [
                "export",
                str(models / "sf_control.pt"),
                "--prefix",
                "ctl_sf",
                "--controller",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    assert (
        main(["export", str(models / "mlp_calibration.pt"), "--prefix", "cal_mlp", "--out", str(tmp_path)])
        == 0
    )
    capsys.readouterr()
    junit = tmp_path / "pil.xml"
    args = ["pil", str(tmp_path), "--model", str(models / "sf_control.pt"), "--cal-model"]
    args += [
        str(models / "mlp_calibration.pt"),
        "--core",
        "cortex-m0plus",
        "--ticks",
        "30",
        "--actuators",
        "2",
    ]
    assert main([*args, "--json", "--junit", str(junit)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["ok"] and doc["instructions"]["ticks"] == 90 and doc["instructions"]["instr_mean"] > 1000
    assert b"seagen.pil.ctl_sf" in junit.read_bytes()


@pytest.mark.slow
@pytest.mark.parametrize("core", CORES)
def test_paper_experiment_on_the_board(core, tmp_path, capsys):
    """The whole experiment (10 contact angles x 5/10/15 N x 6 s) with the MLP exports built with the core's
    kernels: every tick of every actuator bit-identical to the twins (about a minute per core)."""
    models = GENERATED / "models"
    ctl, cal = str(models / "mlp_control.pt"), str(models / "mlp_calibration.pt")
    out = ["--target", core, "--out", str(tmp_path)]
    assert main(["export", ctl, "--prefix", "ctl_mlp", "--controller", *out]) == 0
    assert main(["export", cal, "--prefix", "cal_mlp", *out]) == 0
    capsys.readouterr()
    assert main(["pil", str(tmp_path), "--model", ctl, "--cal-model", cal, "--core", core, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["ok"] and doc["instructions"]["ticks"] == 3 * 600


def test_cli_pil_refuses_a_calibration_model_of_another_actuator(tmp_path, capsys):
    """--cal-model trained for another actuator than --model's (the plant's): exit 2, one line naming the
    file and both actuators, before any board boots (~3 s)."""
    from seagen.actuator import load_actuator
    from seagen.modelfile import load_model, save_model

    example = load_actuator(EXAMPLE_ACTUATOR)
    models = GENERATED / "models"
    cal = load_model(models / "sf_calibration.pt")
    cal["actuator"] = example.record()  # the same fit, recorded as the example design's
    save_model(cal, tmp_path / "cal_other.pt")
    fw = tmp_path / "fw"
    ctl = str(models / "sf_control.pt")
    assert main(["export", ctl, "--prefix", "ctl_sf", "--controller", "--out", str(fw)]) == 0
    assert main(["export", str(tmp_path / "cal_other.pt"), "--prefix", "cal_sf", "--out", str(fw)]) == 0
    capsys.readouterr()
    args = ["pil", str(fw), "--model", ctl, "--cal-model", str(tmp_path / "cal_other.pt")]
    assert main([*args, "--core", "cortex-m4", "--ticks", "5", "--actuators", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "cal_other.pt" in err and example.digest()[:12] in err and "trained for" in err
