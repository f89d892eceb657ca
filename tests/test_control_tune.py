"""The tuning objective behind DEFAULT_PID (seagen.control.tune)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from seagen.control.tune import objective

SF_PAPER = {5.0: 0.32, 10.0: 0.50, 15.0: 0.58}


def test_objective_is_worst_mlp_target_plus_mean_when_sf_is_inside_the_paper_window():
    mlp = {5.0: 0.2, 10.0: 0.4, 15.0: 0.6}
    assert abs(objective(mlp, SF_PAPER) - (0.6 + 0.3 * 0.4)) < 1e-12


def test_objective_penalizes_sf_outside_plus_minus_50_percent_of_the_paper():
    mlp = {5.0: 0.2, 10.0: 0.4, 15.0: 0.6}
    inside = objective(mlp, {5.0: 0.47, 10.0: 0.26, 15.0: 0.86})
    slow = objective(mlp, {5.0: 0.58, 10.0: 0.50, 15.0: 0.58})  # 0.1 s above 1.5 x 0.32 at 5 N
    fast = objective(mlp, {5.0: 0.32, 10.0: 0.15, 15.0: 0.58})  # 0.1 s below 0.5 x 0.50 at 10 N
    assert abs(inside - 0.72) < 1e-12 and abs(slow - 1.02) < 1e-9 and abs(fast - 1.02) < 1e-9


def test_shipped_parameters_are_the_defaults():
    """The tuner's baseline trial is exactly what ships (DEFAULT_PID and the MLP prediction average)."""
    from seagen.control.tune import SHIPPED
    from seagen.runtime.pid import DEFAULT_PID, MOTOR_MAX_MV, TICK_S, PidParams
    from seagen.setups.shipped import CONFIGS

    p = dict(SHIPPED)
    pred_avg = p.pop("pred_avg")
    assert PidParams.from_si(**p, max_mv=MOTOR_MAX_MV, tick_s=TICK_S) == DEFAULT_PID
    assert CONFIGS["mlp_mcu"]()[1].pred_avg == pred_avg and CONFIGS["mlp_mcu"]()[1].pid == DEFAULT_PID


def test_search_space_is_the_papers_on_the_paper_and_carried_to_another_design():
    """The paper's ranges on its own actuator (the shipped search unchanged); on the example, widened: the
    gains' by the ratio of the nut's speed per volt, kp's and ki's also by the compression the stalled
    motor holds per volt, the margin's top moved by the springs' ratio (the same force), its bottom
    widened, the limit's like the calibration pushes' volts, within the supply; at a fast loop the
    derivative gain's top is what the C's Q12 int32 holds."""
    import dataclasses

    from seagen.actuator import default_actuator, load_actuator
    from seagen.control.tune import GAIN_HEADROOM, PAPER_SPACE, search_space
    from seagen.data.protocol import force_scale, volts_scale
    from seagen.plant.config import Motor
    from seagen.runtime.pid import gain_max_si
    from tests.conftest import EXAMPLE_ACTUATOR

    paper = default_actuator()
    assert search_space(paper) == PAPER_SPACE
    ex = load_actuator(EXAMPLE_ACTUATOR)
    space = search_space(ex)
    gain = (Motor.of(paper).v_max_mm_s / 12.0) / (Motor.of(ex).v_max_mm_s / ex.motor.supply_v)

    def widened(lo: float, hi: float, by: float) -> tuple[float, float]:
        return lo * min(by, 1.0), hi * max(by, 1.0)

    hold = (150.0 / 12.0 / 4.2) / (ex.motor.stall_force_n / ex.motor.supply_v / ex.stiffness_n_per_mm)
    assert gain != pytest.approx(1.0, abs=0.05) and hold > gain > 1.0
    assert space["kp_v_mm"] == pytest.approx(widened(20, 40, hold))
    assert space["ki_v_mm_s"] == pytest.approx(widened(2, 8, hold))
    assert space["kd_v_s_mm"] == pytest.approx(widened(0.5, 1.2, gain))
    assert space["margin_mm"] == pytest.approx((0.02 * 4.2 / 8.4, 0.05 * 4.2 / 8.4))
    lim = volts_scale(ex) * force_scale(ex)
    assert lim != pytest.approx(1.0, abs=0.05)
    assert space["limit_v"] == pytest.approx(tuple(min(v, 24.0) for v in widened(6, 10, lim)))
    fast = dataclasses.replace(ex, loop_hz=500.0)
    kd_top = GAIN_HEADROOM * gain_max_si(1 / 500.0)["kd_v_s_mm"]
    assert search_space(fast)["kd_v_s_mm"][1] == pytest.approx(min(widened(0.5, 1.2, gain)[1], kd_top))
    slow = dataclasses.replace(ex, motor=dataclasses.replace(ex.motor, no_load_rpm=600.0), loop_hz=1000.0)
    top_1k = GAIN_HEADROOM * gain_max_si(1e-3)["kd_v_s_mm"]  # a slow motor's range reaches above it
    assert search_space(slow)["kd_v_s_mm"] == pytest.approx((0.5, top_1k)) and top_1k < 1.2


def test_the_margin_dead_band_stays_inside_the_settling_band_on_every_design():
    """The margin is a dead band on the compression error: the loop stops where it enters it. Its top in
    force (margin x spring) is the paper's top, 0.21 N, 70 % of the +-0.3 N settling band, on every
    shipped design and the paper's (fast_48v's search reached 0.05 mm, 0.59 N on its 12 N/mm spring, and
    its SF loop stopped 0.46-0.48 N off); the paper's exactly 0.05 mm."""
    from pathlib import Path

    from seagen.actuator import default_actuator, load_actuator
    from seagen.control.experiment import BAND_N
    from seagen.control.tune import MARGIN_TOP_N, search_space

    assert abs(MARGIN_TOP_N - 0.21) < 1e-12 and MARGIN_TOP_N <= 0.7 * BAND_N + 1e-12
    assert search_space(default_actuator())["margin_mm"][1] == 0.05
    examples = sorted((Path(__file__).parents[1] / "examples" / "actuators").glob("*.toml"))
    assert len(examples) >= 3
    for path in examples:
        act = load_actuator(path)
        lo, hi = search_space(act)["margin_mm"]
        assert 0 < lo < hi and hi * act.stiffness_n_per_mm == pytest.approx(MARGIN_TOP_N), path.name
        assert act.control.margin_mm * act.stiffness_n_per_mm <= MARGIN_TOP_N + 1e-9, path.name


def test_a_gain_the_c_cannot_hold_is_refused_naming_the_field_and_its_bound(tmp_path, capsys):
    """A derivative gain whose Q12 integer overflows int32 at the loop rate: PidParams.from_si raises
    GainRangeError with the field and the largest gain that fits (it was an OverflowError traceback in
    cffi), and a description carrying it is refused when given (exit 2, one line, nothing written)."""
    from seagen.cli import main
    from seagen.runtime.pid import GainRangeError, PidParams, gain_max_si
    from tests.conftest import EXAMPLE_ACTUATOR

    top = gain_max_si(1 / 500.0)["kd_v_s_mm"]
    rest = {"margin_mm": 0.02, "limit_v": 6.5, "max_mv": 12000, "tick_s": 1 / 500.0}
    PidParams.from_si(30.0, 5.0, top * 0.999, 0.9, **rest)
    with pytest.raises(GainRangeError, match=r"control\.kd_v_s_per_mm 3 V s/mm at 500 Hz .*at most 1\.049"):
        PidParams.from_si(30.0, 5.0, 3.0, 0.9, **rest)
    bad = tmp_path / "kd.toml"
    bad.write_text(EXAMPLE_ACTUATOR.read_text() + "kd_v_s_per_mm = 30.0\n")  # [control] is the last table
    out = tmp_path / "data"
    assert main(["data", "generate", "--out", str(out), "--actuator", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(bad) in err and "control.kd_v_s_per_mm 30" in err and not out.exists()


def test_tune_on_another_design_prints_control_lines_the_description_takes(tmp_path, capsys):
    """`seagen tune --actuator` on the example (no model: kin_mcu), one trial: the first trial is the
    description's own settings carried into its space; the printed [control] lines, pasted into the
    description, load and quantize; bad counts exit 2 (~5 s)."""
    import json

    from seagen.actuator import load_actuator
    from seagen.cli import main
    from seagen.runtime.actq import act_q
    from seagen.runtime.control import ControlConfig
    from tests.conftest import EXAMPLE_ACTUATOR

    assert main(["tune", "--trials", "0"]) == 2 and "--trials" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text("kind = 3\n")
    assert main(["tune", "--actuator", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(bad) in err
    assert main(["tune", "--actuator", str(EXAMPLE_ACTUATOR), "--trials", "1", "--seeds", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["configuration"] == "kin_mcu" and set(out["settling_s"]["kin_mcu"]) == {"5", "10", "15"}
    assert out["first_trial_settling_s"] == out["settling_s"]  # one trial: the description's own settings
    assert out["control"].startswith("# seagen tune: set these in your description's [control] table")
    text = EXAMPLE_ACTUATOR.read_text()
    lines = out["control"].splitlines()[1:]
    keys = {x.split(" = ")[0] for x in lines}
    assert keys == {"kp_v_per_mm", "ki_v_per_mm_s", "kd_v_s_per_mm", "d_alpha", "margin_mm", "limit_v"}
    kept = [x for x in text.splitlines() if x.split(" = ")[0].strip() not in keys]
    mine = tmp_path / "tuned.toml"
    mine.write_text("\n".join(kept + lines) + "\n")  # [control] is the example's last table
    act = load_actuator(mine)
    ControlConfig.for_act(act_q(act))
    assert {k: getattr(act.control, k) for k in keys} == {
        x.split(" = ")[0]: float(x.split(" = ")[1]) for x in lines
    }


def _record(force: np.ndarray, off_n: np.ndarray, k: float = 4.2, hz: float = 100.0) -> dict:
    """A one-actuator record: reference force `force` (N, per tick, contact from the first tick) and the
    loop's own error `off_n` (desired minus measured compression, as a force on the `k` N/mm spring)."""
    n = len(force)
    col = lambda x: np.asarray(x, float).reshape(n, 1)  # noqa: E731
    desired = np.full((n, 1), 3 << 16, dtype=np.int64)
    comp = desired - np.round(col(off_n) / k * 65536).astype(np.int64)
    return {
        "t_s": col(np.arange(n) / hz),
        "force_n": col(force),
        "true_force_n": col(np.maximum(force, 1e-3)),
        "target_n": col(np.full(n, 5.0)),
        "desired": desired,
        "comp": comp,
    }


def test_held_settling_sees_a_loop_held_off_its_setpoint():
    """settling_held_s (tune's score of kin_mcu, whose estimate is biased): a force steady from 1 s on
    settles to its final level by 1 s either way, but with the loop's own error 0.5 N (a droop, a dead
    band, a command at its limit) it never settles held; with the error inside the band from 2 s, at 2 s."""
    from seagen.control.experiment import metrics

    t = np.arange(600) / 100.0
    force = np.where(t < 1.0, 4.0 * t, 4.0)
    held_off = metrics(_record(force, np.full(600, 0.5)), 4.2)
    assert 0.9 <= held_off["settling_final_s"][0] <= 1.0  # within 0.3 N of 4 N from 0.925 s, smoothed
    assert np.isnan(held_off["settling_held_s"][0])
    settles = metrics(_record(force, np.where(t < 2.0, 0.5, 0.1)), 4.2)
    assert settles["settling_held_s"][0] == pytest.approx(2.0, abs=0.06)
    assert "settling_held_s" not in metrics(_record(force, np.zeros(600)))


def test_tunes_second_trial_is_the_papers_settings_carried_to_the_design():
    """On another design the search's second trial is the paper's shipped settings carried by the ratios
    that widen its space (kp, ki: the compression held per volt; kd: the nut speed per volt; the margin:
    the springs; the limit: the calibration pushes' volts): on fast_48v within 15 % of the gains its
    24-trial search found (kp 152.5, ki 24.31), on a design paced slower the limit its supply, as its pushes
    and its paced runs are at full supply."""
    import dataclasses

    from seagen.actuator import load_actuator
    from seagen.control.tune import carried_trial, search_space
    from seagen.data.reach import pace

    root = Path(__file__).parents[1] / "examples" / "actuators"
    fast = carried_trial(load_actuator(root / "fast_48v.toml"))
    assert fast["kp_v_mm"] == pytest.approx(152.5, rel=0.15) and fast["ki_v_mm_s"] == pytest.approx(
        24.31, rel=0.15
    )
    micro = load_actuator(root / "micro_6v.toml")
    assert pace(micro) > 1.0 and carried_trial(micro)["limit_v"] == micro.motor.supply_v
    slow = dataclasses.replace(
        micro, motor=dataclasses.replace(micro.motor, supply_v=24.0, stall_force_n=600.0)
    )
    assert pace(slow) > 1.0 and search_space(slow)["limit_v"][1] == 24.0 == carried_trial(slow)["limit_v"]


def test_the_limit_grid_keeps_its_top_and_optuna_takes_it_whole():
    """The limit's grid runs LIMIT_STEPS steps down from the range's top (the supply on a paced design)
    in decimals optuna finds divisible: before, a drawn 3.7 V design's 2.3125-3.7 V range by 0.1734375 V
    was cut to 3.53 V by optuna (a warning), and the paper's settings carried there (3.7 V) fell outside it.
    The paper's grid is exactly 6-10 V by 0.5 V."""
    import warnings

    from optuna.distributions import FloatDistribution

    from seagen.control.tune import LIMIT_STEPS, _limit_grid

    assert _limit_grid(6.0, 10.0) == (6.0, 10.0, 0.5)
    for lo, hi in ((2.3125, 3.7), (2.0368377483443716, 3.7), (6.0, 38.828467590189966), (1.0, 1.00001)):
        low, high, step = _limit_grid(lo, hi)
        assert lo <= low <= high <= hi and hi - high < 1e-4
        if step == 0:
            assert hi - lo < LIMIT_STEPS * 1e-4
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            d = FloatDistribution(low, high, step=step)
        assert d.high == high and high - low == pytest.approx(LIMIT_STEPS * step)
