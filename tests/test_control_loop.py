"""Closed loop: C and Python controllers give the same trajectory exactly; faults in the loop; the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from seagen.cli import main
from seagen.control.experiment import metrics
from seagen.control.loop import run_closed_loop
from seagen.control.predictors import kinematic_cloud, kinematic_mcu
from seagen.runtime import control as ct

ANGLES = np.array([8.0, 14.0, 22.0])
CASES = [  # (name, predictor factory, target N, duration s)
    ("kin_mcu_100hz", lambda: kinematic_mcu(1), 10.0, 10.0),
    ("kin_mcu_10hz", lambda: kinematic_mcu(10), 15.0, 3.0),
    ("kin_cloud", lambda: kinematic_cloud(0.1, 10.0), 5.0, 3.0),
]


@pytest.mark.parametrize("name,make,target,duration", CASES, ids=[c[0] for c in CASES])
def test_c_and_twin_same_trajectory(name, make, target, duration):
    """Every controller output, controller field, sensor and plant state is identical (C vs Python)."""
    runs = [run_closed_loop(make(), target, ANGLES, impl=i, duration_s=duration, seed=4) for i in ("c", "py")]
    for key in runs[0]:
        a, b = runs[0][key], runs[1][key]
        if not np.array_equal(a, b):
            k = int(np.argmax((a != b).reshape(a.shape[0], -1).any(axis=1)))
            pytest.fail(f"{key} differs first at tick {k}: C {a[k]} vs Python {b[k]}")
    assert runs[0]["out_mv"].any() and (runs[0]["true_force_n"][-1] > 1.0).all()


def _pot_stuck(value: int):
    return lambda k, enc, pot: (enc, np.full_like(pot, value) if k >= 100 else pot)


def _enc_jump(k, enc, pot):
    return (enc + 1000 if k >= 100 else enc), pot


LOOP_FAULTS = [  # (name, sensor hook, target N per tick, expected fault bits, first faulted tick)
    ("pot_stuck_low", _pot_stuck(0), lambda k: 10.0, ct.FAULT_POT_STUCK_LOW, 100 + ct.POT_STUCK_TICKS - 1),
    (
        "pot_stuck_high",
        _pot_stuck(4095),
        lambda k: 10.0,
        ct.FAULT_POT_STUCK_HIGH,
        100 + ct.POT_STUCK_TICKS - 1,
    ),
    ("enc_jump", _enc_jump, lambda k: 10.0, ct.FAULT_ENC_JUMP, 100),
    ("force_range", None, lambda k: 10.0 if k < 100 else 25.0, ct.FAULT_FORCE_RANGE, 100),
]


@pytest.mark.parametrize("name,hook,target,bits,tick", LOOP_FAULTS, ids=[f[0] for f in LOOP_FAULTS])
@pytest.mark.parametrize("impl", ["c", "py"])
def test_fault_in_loop(name, hook, target, bits, tick, impl):
    """In the loop the fault latches at its tick with its code and the motor stays off afterwards."""
    r = run_closed_loop(kinematic_mcu(), target, ANGLES, impl=impl, duration_s=2.0, sensor_hook=hook)
    assert (r["fault"][:tick] == 0).all() and (r["fault"][tick:] == bits).all()
    assert (r["out_mv"][tick:] == 0).all() and r["out_mv"][:tick].any()


def test_kinematic_loop_settles():
    """With the kinematic predictor the loop settles to its own final force within 0.6 s of contact."""
    r = run_closed_loop(kinematic_mcu(), 10.0, ANGLES, duration_s=4.0, seed=1)
    m = metrics(r)
    assert np.all(m["settling_final_s"] < 0.6), m


def test_cli_simulate_json(capsys):
    """`seagen simulate --json` prints {config: {"5","10","15": {error_avg_n, settling_s}}}."""
    assert main(["simulate", "--json", "--config", "kin_mcu"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"kin_mcu"} and set(out["kin_mcu"]) == {"5", "10", "15"}
    for r in out["kin_mcu"].values():
        assert {"error_avg_n", "settling_s"} <= set(r) and r["error_avg_n"] >= 0


def test_cli_bad_latency(capsys):
    """A negative latency is a user error (exit 2) naming the option."""
    assert main(["simulate", "--latency", "-1"]) == 2
    assert "--latency" in capsys.readouterr().err


def test_cli_simulate_seed_sweep_is_the_mean_of_single_seeds(capsys, monkeypatch):
    """`--seeds 2` reports per target the mean of the two single-seed runs and their settling range (the
    experiment shortened for time: 4 contact angles, 3 s runs)."""
    from seagen.control import experiment

    monkeypatch.setattr(experiment, "N_CONTACT", 4)
    monkeypatch.setattr(experiment, "DURATION_S", 3.0)
    runs = []
    for seed in (3, 4):
        assert main(["simulate", "--json", "--config", "kin_mcu", "--seed", str(seed)]) == 0
        runs.append(json.loads(capsys.readouterr().out)["kin_mcu"])
    assert main(["simulate", "--json", "--config", "kin_mcu", "--seed", "3", "--seeds", "2"]) == 0
    swept = json.loads(capsys.readouterr().out)["kin_mcu"]
    for t, r in swept.items():
        one = [x[t] for x in runs]
        st = [x["settling_s"] for x in one if x["settling_s"] is not None]
        assert abs(r["error_avg_n"] - np.mean([x["error_avg_n"] for x in one])) < 1e-4
        assert r["settled"] == sum(x["settled"] for x in one) and r["angles"] == 2 * experiment.N_CONTACT
        assert (r["settling_min_s"], r["settling_max_s"]) == ((min(st), max(st)) if st else (None, None))


def test_cli_bad_seeds(capsys):
    """--seeds below 1 is a user error (exit 2) naming the option."""
    assert main(["simulate", "--seeds", "0"]) == 2
    assert "--seeds" in capsys.readouterr().err


def test_table_without_paper_figures_drops_the_paper_columns_and_aligns():
    """Targets the paper did not run (another design's 3.75/7.5/11.25 N) or a plant of another design: no
    paper column (no `nan`); every row as wide as the header, the force column right-aligned; the paper's
    targets keep the paper's columns."""
    from seagen.control.experiment import format_table2

    row = {"error_avg_n": 0.1, "settling_s": 1.0, "settled": 9, "angles": 10, "settling_final_s": 0.2}
    table = {"ctl_mlp_mcu": {t: dict(row) for t in ("3.75", "7.5", "11.25")}}
    lines = format_table2(table, {"ctl_mlp_mcu": "MLP"}).splitlines()
    assert "paper" not in lines[0] and not any("nan" in x or "MLP" in x for x in lines)
    assert len({len(x) for x in lines}) == 1 and lines[0].index("force") + 5 == lines[3].index(" N") + 2
    paper = {"sf_mcu": {t: dict(row) for t in ("5", "10", "15")}}
    assert "paper" in format_table2(paper) and "paper" not in format_table2(paper, paper_figures=False)
    assert "0.29" in format_table2(paper).splitlines()[1]  # the paper's SF error at 5 N


def test_cloud_kinematic_inverse_is_the_given_actuators():
    """The cloud's float kinematic inverse reads the description it is given: compression = (F + its
    friction) / its spring rate, not the paper's numbers."""
    from seagen.actuator import load_actuator
    from seagen.geometry import geometry
    from tests.conftest import EXAMPLE_ACTUATOR

    act = load_actuator(EXAMPLE_ACTUATOR)
    force = np.array([0.0, 5.0, 12.5])
    got = kinematic_cloud(0.1, 10.0, geometry(act)).fn(None, None, force)
    assert np.allclose(got, (force + act.friction_n) / act.stiffness_n_per_mm)
    paper = kinematic_cloud(0.1, 10.0).fn(None, None, force)
    assert not np.allclose(got, paper)


def test_runs_stuck_at_the_command_limit_are_named():
    """A run that never settles and sits at +-limit_v after contact counts toward the share at the limit
    (settled runs and ticks before contact do not); `simulate` then prints a note naming the limit, where
    it comes from and the field to change, and prints 'never' (no nan, no warning) for a settling time to
    the final force that no run reached."""
    import dataclasses
    import warnings

    from seagen.actuator import default_actuator
    from seagen.cli.control import limit_notes
    from seagen.control.experiment import format_table2, limit_share

    act = default_actuator()
    act48 = dataclasses.replace(act, motor=dataclasses.replace(act.motor, supply_v=48.0))
    lim = round(act.control.limit_v * 1000)
    out = np.array([[0, 0, 0], [lim, 0, -lim], [lim, lim, -lim], [lim - 1, lim, -lim]])
    rec = {"out_mv": out, "true_force_n": np.array([[0, 0, 0], [1, 0, 1], [1, 1, 1], [1, 1, 1]])}
    # column 0: 2 of 3 ticks after contact at the limit; 1: settled (ignored); 2: 3 of 3
    assert limit_share(rec, np.array([np.nan, 0.5, np.nan]), lim) == 5 / 6
    assert limit_share(rec, np.array([0.1, 0.5, 0.2]), lim) == 0.0
    row = {"error_avg_n": 9.0, "settling_s": None, "settled": 0, "angles": 10, "settling_final_s": None}
    table = {"kin_mcu": {"30": {**row, "at_limit": 0.85}, "15": {**row, "at_limit": 0.2}}}
    (note,) = limit_notes(table, act48)
    assert "+-6.5 V" in note and "control.limit_v" in note and "supply 48 V" in note and "30 N (85%)" in note
    assert "15 N" not in note
    assert limit_notes({"kin_mcu": {"15": table["kin_mcu"]["15"]}}, act48) == []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert "never" in format_table2(table, paper_figures=False).splitlines()[1].split()[-1]
