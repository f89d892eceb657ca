"""The tuning objective behind DEFAULT_PID (seagen.control.tune)."""

from __future__ import annotations

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
    from seagen.control.experiment import CONFIGS
    from seagen.control.tune import SHIPPED
    from seagen.runtime.pid import DEFAULT_PID, MOTOR_MAX_MV, TICK_S, PidParams

    p = dict(SHIPPED)
    pred_avg = p.pop("pred_avg")
    assert PidParams.from_si(**p, max_mv=MOTOR_MAX_MV, tick_s=TICK_S) == DEFAULT_PID
    assert CONFIGS["mlp_mcu"](0.1)[1].pred_avg == pred_avg and CONFIGS["mlp_mcu"](0.1)[1].pid == DEFAULT_PID


def test_another_actuator_is_tuned_on_its_own_plant_near_its_own_gains(monkeypatch):
    """`--actuator`: kin_mcu on the described plant, its targets, each gain searched within SCALE of the
    description's own (here kp 50 V/mm: 25 to 100) and the command limit within its supply; the first trial is
    the description's setting (one trial, 0.5 s runs: ~5 s)."""
    from seagen.actuator import actuator_from_dict, load_actuator
    from seagen.control import experiment
    from seagen.control.tune import tune_actuator
    from tests.conftest import EXAMPLE_ACTUATOR

    monkeypatch.setattr(experiment, "DURATION_S", 0.5)
    d = load_actuator(EXAMPLE_ACTUATOR).to_dict()
    d["control"]["kp_v_per_mm"] = 50.0
    act = actuator_from_dict(d, "kp 50")
    (trial,) = tune_actuator(act, 1, (0,)).trials
    assert trial.params["kp_v_mm"] == 50.0 and trial.params["margin_mm"] == act.control.margin_mm
    kp, limit = trial.distributions["kp_v_mm"], trial.distributions["limit_v"]
    assert (kp.low, kp.high) == (25.0, 100.0) and limit.high == act.motor.supply_v
    assert set(trial.user_attrs["kin_mcu"]) == set(experiment.targets_n(act))


def test_tune_refuses_a_bad_description(tmp_path, capsys):
    """A description that cannot be read: one line naming the file, exit 2."""
    from seagen.control.tune import main

    bad = tmp_path / "bad.toml"
    bad.write_text("kind = 3\n")
    assert main(["--actuator", str(bad), "--trials", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(bad) in err
