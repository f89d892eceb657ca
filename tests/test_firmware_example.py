"""examples/firmware (seven SEAs, one 100 Hz tick) builds for Cortex-M4 and M0+ from one export folder and
runs on the emulated cores equal to the Python twins bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.bench.glove import N_SEA, TICKS, glove_files, sensors
from seagen.codegen.controller import shipped_config
from seagen.control.gentwin import StepTwin
from seagen.defaults import GENERATED
from seagen.export import prepare
from seagen.reference import numpy_ref
from seagen.runtime import features as F
from seagen.runtime.actq import act_q_of
from seagen.runtime.control import ControlConfig, control_reset, control_step
from seagen.setups.shipped import export as default_ir
from seagen.toolchain.cortexm import CPUS, Machine, build_image, toolchain_missing

pytest.importorskip("unicorn", reason="unicorn (the Cortex-M emulator) is not installed: pip install unicorn")


@pytest.fixture(scope="module")
def want():
    """The sensor sequence and what the Python twins make of it: (enc, pot, force, motor, force estimates)."""
    cal = prepare(str(GENERATED / "models" / "mlp_calibration.pt"), prefix="cal_mlp")
    enc, pot, force = sensors(7)
    return (enc, pot, force, *_twins(cal.qmodel, enc, pot, force))


def _twins(cal_qm, enc, pot, force, ctl: str = "ctl_mlp") -> tuple[np.ndarray, np.ndarray]:
    """Motor commands (controller twin + StepTwin of `ctl`, the shipped configuration) and force estimates
    (the feature pipeline's twin + numpy_ref) per tick, for the batch of actuators."""
    cfg = shipped_config(default_ir(ctl).qmodel)
    c = ControlConfig(**{**cfg.__dict__, "predictor": StepTwin(ctl, default_ir(ctl).qmodel)})
    s, pipe = control_reset(c, enc[0], pot[0]), F.Pipeline(act_q_of())
    motor, est = [], []
    for k in range(TICKS):
        b, d, dd = pipe.step(enc[k], pot[k])
        est.append(numpy_ref.infer(cal_qm, F.inputs(act_q_of(), cal_qm.inputs, b, d, dd, None)))
        s = control_step(c, s, enc[k], pot[k], force[k])
        motor.append(s.out)
    return np.array(motor), np.array(est)


def _run(files: dict[str, str], cpu: str, enc, pot, force) -> tuple[np.ndarray, np.ndarray, int]:
    """glove_init + TICKS glove_tick calls on the emulated core: motor commands, force estimates and the
    instructions of one tick (the larger of ticks 60 and 61)."""
    m = Machine(build_image(files, cpu, ("glove_init", "glove_tick"), name="glove"), cpu)
    i32 = np.int32
    g = m.call("glove_init", np.zeros(16384, np.uint8), enc[0].astype(i32), pot[0].astype(i32))[0][0]
    motor, est, counts = [], [], []
    for k in range(TICKS):
        out, fe = np.zeros(N_SEA, np.int32), np.zeros(N_SEA, np.int16)
        args = (g, enc[k].astype(i32), pot[k].astype(i32), force[k].astype(i32), out, fe)
        back, n = m.call("glove_tick", *args, count=k in (60, 61))
        g = back[0]
        motor.append(back[4])
        est.append(back[5])
        counts += [n] if n else []
    return np.array(motor), np.array(est), max(counts)


@pytest.mark.parametrize("target", ["core", "portable"])
@pytest.mark.parametrize("cpu", CPUS)
def test_glove_tick_on_core(want, cpu, target):
    """The example built from the README's exports (with `--target` the core's kernels, or portable):
    glove_init + TICKS glove_tick calls on the emulated core == the Python twins; prints the instructions
    of one tick of seven actuators."""
    if msg := toolchain_missing():
        pytest.skip(msg)
    enc, pot, force, want_motor, want_est = want
    motor, est, n = _run(glove_files(cpu if target == "core" else "portable"), cpu, enc, pot, force)
    assert np.array_equal(est, want_est), "force estimates differ"
    assert np.array_equal(motor, want_motor), "motor commands differ"
    assert np.abs(want_motor).max() > 0
    print(f"{cpu} ({target} kernels): one glove tick = {n} instructions")


def test_glove_with_sf_predictor_on_m0plus(want):
    """The example with ctl_mlp renamed ctl_sf (the bench's SF-predictor glove, M0+ kernels) == the twins
    with the SF predictor in its shipped configuration (~3 s)."""
    if msg := toolchain_missing():
        pytest.skip(msg)
    enc, pot, force, _, want_est = want
    cal = prepare(str(GENERATED / "models" / "mlp_calibration.pt"), prefix="cal_mlp")
    want_motor, _ = _twins(cal.qmodel, enc, pot, force, ctl="ctl_sf")
    files = glove_files("cortex-m0plus", "cal_mlp", "ctl_sf")
    motor, est, _ = _run(files, "cortex-m0plus", enc, pot, force)
    assert np.array_equal(est, want_est), "force estimates differ"
    assert np.array_equal(motor, want_motor), "motor commands differ"
    assert np.abs(want_motor).max() > 0


def test_cli_export_controller(tmp_path, capsys):
    """`seagen export --controller` writes NAME_controller.h/.c and sea_pid/sea_control beside the model;
    on a calibration model it is one clear error line and exit 2, nothing written."""
    from seagen.cli import main

    models = GENERATED / "models"
    assert (
        main(
            [
                "export",
                str(models / "sf_control.pt"),
                "--prefix",
                "c_sf",
                "--controller",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    names = {p.name for p in tmp_path.iterdir()}
    assert {"c_sf_controller.h", "c_sf_controller.c", "sea_pid.c", "sea_control.h", "c_sf.c"} <= names
    out = tmp_path / "cal"
    assert main(["export", str(models / "sf_calibration.pt"), "--controller", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--controller needs a control model" in err[0] and not out.exists()
