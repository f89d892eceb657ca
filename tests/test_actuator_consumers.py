"""Consumers that must read the actuator (or the record of its loop) rather than the paper's numbers: the
experiment's smoothing window, the discrepancy report's force regions, the replay's neutral series
compliance, verify's controller sequence, export's calibration ranges."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from seagen.actuator import actuator_from_dict, default_actuator, load_actuator
from seagen.control.experiment import SMOOTH_S, smoothed
from seagen.data.protocol import Move, run_trials
from seagen.discrepancy.replay import Runs, runs_from_frames, simulate
from seagen.discrepancy.residuals import region_labels
from seagen.plant import PlantConfig
from seagen.runtime.actq import act_q
from seagen.runtime.control import ControlConfig, control_reset, control_step
from seagen.verify.tick import sequence
from tests.conftest import EXAMPLE_ACTUATOR as EXAMPLE


@pytest.mark.parametrize("loop_hz", [default_actuator().loop_hz, load_actuator(EXAMPLE).loop_hz])
def test_smoothing_window_is_50_ms_at_any_loop_rate(loop_hz):
    """A force step is fully in the trailing mean SMOOTH_S after it: 5 ticks at 100 Hz, 10 at 200 Hz."""
    n = round(SMOOTH_S * loop_hz)
    t = np.arange(40) / loop_hz
    force = (np.arange(40) >= 20).astype(float)
    f = smoothed({"t_s": t[:, None], "force_n": force[:, None]})[:, 0]
    assert f[20 + n - 2] < 1.0 and f[20 + n - 1] == 1.0


def test_force_regions_are_shares_of_the_force_range():
    """The report's force regions: 1, 5, 10 N on the paper's 20 N range; 5, 25, 50 N on a 100 N one."""
    t = np.arange(6) / 100.0
    frame = {"trial": 0, "t_s": t, "angle_set_deg": 12.0, "motor_v": 0.0, "enc": 0, "pot": 2000}
    df = pd.DataFrame({**frame, "load_cell_n": 0.0, "force_n": [0.5, 3.0, 7.0, 12.0, 30.0, 60.0]})
    runs = runs_from_frames([("x", df)])
    d = default_actuator().to_dict()
    d["control"]["force_max_n"] = 100.0
    strong = actuator_from_dict(d, "100 N")
    paper = region_labels(runs, PlantConfig().motor, default_actuator().control.force_max_n)["force"][0]
    big = region_labels(runs, PlantConfig(actuator=strong).motor, 100.0)["force"][0]
    assert list(paper) == ["<1 N", "1-5 N", "5-10 N", ">10 N", ">10 N", ">10 N"]
    assert list(big) == ["<5 N", "<5 N", "5-25 N", "5-25 N", "25-50 N", ">50 N"]


def test_runs_need_their_logged_instants():
    """Runs without the logged instants is refused (no loop rate is assumed for them)."""
    meas = {c: np.zeros((1, 3)) for c in ("enc", "pot", "load_cell_n", "force_n")}
    with pytest.raises(ValueError, match="Runs.t"):
        Runs(np.zeros(1), np.zeros((1, 3)), meas, np.ones((1, 3), bool), ["x"], np.zeros((0, 0)))


def test_verify_sequence_runs_the_controller_on_a_fast_loop():
    """verify's controller sequence on the paper's motor at a 1 kHz loop (encoder-jump bound 13 counts per
    tick): its encoder steps stay within the bound, so the controller ticks without a fault (a walk of the
    paper's 40-count steps would latch the encoder-jump fault at once and compare only zeros)."""
    d = default_actuator().to_dict()
    d["control"]["loop_hz"] = 1000.0
    d["control"]["kd_v_s_per_mm"] = 0.4  # the paper's 0.85 V s/mm does not fit the C's Q12 kd at 1 kHz
    aq = act_q(actuator_from_dict(d, "1 kHz"))
    assert aq.enc_jump_max < 40
    qm = SimpleNamespace(inputs=[SimpleNamespace(signal=SimpleNamespace(name="force_n", lo=2.0, hi=18.0))])
    enc, pot, force = sequence(qm, act=aq)
    assert np.abs(np.diff(enc)).max() <= aq.enc_jump_max
    cfg = ControlConfig.for_act(aq)
    s = control_reset(cfg, enc[:1], pot[:1])
    for k in range(len(enc)):
        s = control_step(cfg, s, enc[k : k + 1], pot[k : k + 1], force[k : k + 1])
    assert s.fault[0] == 0


@pytest.mark.parametrize("act", [default_actuator(), load_actuator(EXAMPLE)], ids=["paper", "example"])
def test_neutral_series_compliance_is_the_plant_without_it(act):
    """A replayed set that switches series_compliance on at its neutral values moves the plant exactly as
    the base with it off, on either design (the rigid structure is relative to the described spring)."""
    base = PlantConfig(actuator=act).with_effect("series_compliance", False)
    frame = run_trials(base, [Move(12.0, 3.0, 8.0, -6.0, 0.5)], seed=2, max_s=1.0)[0]
    runs = runs_from_frames([("x", frame.assign(trial=0))])
    off = simulate(base, [{}], runs)
    on = simulate(base, [{"series_compliance": {"beta_mm_per_n2": 0.0}}], runs)
    assert all(np.array_equal(off[c], on[c], equal_nan=True) for c in off)


def test_export_calib_ranges_are_the_data_actuator_features(tmp_path):
    """`export --calib DIR`: the feature ranges come from DIR's data on the actuator it was recorded on (its
    actuator.toml: here the example's, its encoder and 200 Hz rows; the paper's geometry refuses the rows)."""
    from seagen.actuator import to_toml
    from seagen.data.features import derive
    from seagen.data.schema import load_split, save_csv
    from seagen.export import calib_ranges
    from seagen.geometry import geometry

    act = load_actuator(EXAMPLE)
    raw = pd.DataFrame(
        {
            "trial": 0,
            "t_s": np.arange(12) / act.loop_hz,
            "angle_set_deg": 12.0,
            "motor_v": 3.0,
            "enc": np.arange(12) * 4000,
            "pot": np.arange(1000, 1012),
            "load_cell_n": 0.0,
            "force_n": np.linspace(0.0, 6.0, 12),
        }
    )
    save_csv(raw, tmp_path / "train.csv")
    (tmp_path / "actuator.toml").write_text(to_toml(act))
    names = ["compression_mm", "angle_deg"]
    df = derive(load_split(tmp_path, "train"), geometry(act))
    assert calib_ranges(str(tmp_path), names) == [[float(df[n].min()), float(df[n].max())] for n in names]


def test_relative_errors_count_rows_above_a_share_of_the_force_range():
    """The paper-style relative errors take rows above 5 N on its 20 N range, 1 N on a 4 N one (its trials
    peak below 5 N: the paper's threshold would leave no row and the errors NaN)."""
    import warnings

    from seagen.data.features import derive
    from seagen.data.protocol import PUSH_MOVES, scaled_move
    from seagen.fit.kinematics import error_threshold_n, kinematics_errors
    from seagen.geometry import geometry

    d = default_actuator().to_dict()
    d["control"]["force_max_n"] = 4.0
    small = actuator_from_dict(d, "4 N")
    assert error_threshold_n(default_actuator()) == 5.0 and error_threshold_n(small) == 1.0
    cfg = PlantConfig(actuator=small)
    frames = run_trials(cfg, [scaled_move(a, PUSH_MOVES[0], small) for a in (8.0, 16.0, 24.0)], seed=1)
    df = derive(
        pd.concat([f.assign(trial=i) for i, f in enumerate(frames)], ignore_index=True), geometry(small)
    )
    assert df.force_n.max() < 5.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no mean of an empty selection
        errs = kinematics_errors(df, geometry(small))
    assert errs["rows"] > 0 and np.isfinite(errs["error_avg_pct"]) and np.isfinite(errs["error_max_pct"])


@pytest.mark.parametrize("loop_hz", [100.0, 200.0])
def test_a_trial_ends_after_the_same_quiet_time_at_any_loop_rate(loop_hz):
    """The calibration protocol ends a retract once the force has stayed below QUIET_N for QUIET_S: the
    trial's last rows span that time at 100 Hz and at 200 Hz (it counted 8 rows: 80 ms at the paper's
    100 Hz, 40 ms at 200 Hz)."""
    import dataclasses

    from seagen.data.protocol import QUIET_N, QUIET_S

    act = dataclasses.replace(default_actuator(), loop_hz=loop_hz)
    # a slow retract: the quiet time ends the trial before the encoder is back home (which ends it too)
    (df,) = run_trials(PlantConfig(actuator=act), [Move(12.0, 3.0, 8.0, -2.0)], seed=1)
    quiet = (df["force_n"] < QUIET_N).to_numpy()[::-1]
    last = int(np.argmin(quiet))  # rows at the end below QUIET_N
    assert last == round(QUIET_S * loop_hz) and df["force_n"].max() >= 8.0 and df["enc"].iloc[-1] > 0


def test_motor_windows_are_the_constants_for_the_shipped_motors_and_grow_with_a_slow_one():
    """The timing's switch-step window and the replay's settle time are at least one and two motor time
    constants: the shipped designs (15 ms, 8 ms) keep the constants, a 60 ms motor gets 60 and 120 ms, and
    identify reads the settle time of the described motor."""
    import dataclasses

    from seagen.discrepancy.replay import SETTLE_S, settle_time
    from seagen.discrepancy.timing import STEP_S, _switch_windows, step_time

    for act in (default_actuator(), load_actuator(EXAMPLE)):
        assert (step_time(act), settle_time(act)) == (STEP_S, SETTLE_S)
    paper = default_actuator()
    slow = dataclasses.replace(paper, motor=dataclasses.replace(paper.motor, time_constant_s=0.06))
    assert (step_time(slow), settle_time(slow)) == (0.06, 0.12)
    t = np.arange(100) * 0.01
    v = np.where(t >= 0.5, 2.0, 1.0)
    runs = Runs(np.array([10.0]), v[None], {}, np.ones((1, 100), bool), ["x"], t[None])
    (_, before, _, after), *_ = [w for w in _switch_windows(runs, 0.06) if w[3][0] > 40]
    assert t[before[0]] == pytest.approx(0.49 - 0.12) and t[after[0]] == pytest.approx(0.49 + 0.06)
