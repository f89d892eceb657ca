"""A design too slow to push to its force range in the protocol's time is refused before any data; the push
time estimate that decides it is a lower bound of the simulated push, within a factor of two."""

from __future__ import annotations

from pathlib import Path

import pytest

from seagen.actuator import default_actuator, load_actuator
from seagen.data.protocol import Move, run_trials
from seagen.data.reach import MAX_PUSH_S, push_time, reach_problem
from seagen.plant import PlantConfig
from tests.conftest import EXAMPLE_ACTUATOR, run_cli

SLOW = Path(__file__).with_name("slow_6v.toml")


@pytest.mark.parametrize("act", [None, EXAMPLE_ACTUATOR], ids=["paper", "stiff_24v"])
def test_push_time_bounds_the_simulated_push(act):
    """The estimate (free approach, then spring compression under the motor's speed-force line) is at most
    the simulated time to the peak and at least half of it (series compliance and friction slow the plant)."""
    a = load_actuator(act) if act else default_actuator()
    volts, peak = 0.25 * a.motor.supply_v, 0.85 * a.control.force_max_n
    df = run_trials(PlantConfig(actuator=a), [Move(a.linkage.angle_max_deg - 2.0, volts, peak, -volts)], 0)[0]
    t_sim = float(df.loc[df.force_n >= peak, "t_s"].iloc[0])
    assert push_time(a, volts, peak) <= t_sim <= 2.0 * push_time(a, volts, peak)


def test_shipped_and_test_designs_are_accepted():
    """The paper's actuator, the shipped example and the slow test design push to their range in time."""
    for act in (default_actuator(), load_actuator(EXAMPLE_ACTUATOR), load_actuator(SLOW)):
        assert reach_problem(act) is None


def test_a_design_too_slow_is_refused_with_its_numbers(tmp_path):
    """Four times slower than the slow test design: refused when the description is given (data generate,
    simulate, tune: exit 2 naming the file, the push time, the speed, the compression and what to change),
    before any work; nothing written."""
    text = SLOW.read_text().replace("no_load_rpm = 12600.0", "no_load_rpm = 3150.0")
    slower = tmp_path / "slower.toml"
    slower.write_text(text)
    act = load_actuator(slower)
    assert push_time(act, act.motor.supply_v, act.control.force_max_n) > MAX_PUSH_S
    out = tmp_path / "data"
    for argv in (("data", "generate", "--out", str(out)), ("simulate", "--config", "kin_mcu"), ("tune",)):
        code, _, err = run_cli(*argv, "--actuator", str(slower))
        assert code == 2 and "Traceback" not in err and str(slower) in err, err
        for word in (
            "s at the full supply",
            "mm/s at the nut",
            "mm of spring compression",
            "motor.gear_ratio",
        ):
            assert word in err, err
    assert not out.exists() or not any(out.iterdir())


def test_protocol_unchanged_where_the_design_is_as_brisk_as_the_papers():
    """On the paper's actuator and the shipped example no push is raised and nothing is stretched: the same
    volts as the stall-force-per-volt scaling gives and a pace of exactly 1 (their data are as before)."""
    from seagen.data.protocol import PUSH_MOVES, force_scale, scaled_move, volts_scale
    from seagen.data.reach import pace

    for act in (default_actuator(), load_actuator(EXAMPLE_ACTUATOR)):
        assert pace(act) == 1.0
        f = volts_scale(act) * force_scale(act)
        for move in PUSH_MOVES:
            assert scaled_move(20.0, move, act).push_v == min(move[0] * f, act.motor.supply_v)


@pytest.mark.slow  # ~5-12 s: 40 s of a slow push at the plant's 1 ms step
def test_slow_design_pushes_at_its_supply_and_reaches_its_peak_within_the_paced_cap():
    """On the slow design every push runs at the supply (slower than the paper's even there), the protocol is
    stretched by the push-time ratio, and a push to 85 % of the range at the top angle ends within the trial
    cap: its rows reach the peak."""
    from seagen.data.protocol import PUSH_MOVES, TRIAL_CAP_S, scaled_move
    from seagen.data.reach import pace

    act = load_actuator(SLOW)
    assert pace(act) > 10
    moves = [scaled_move(act.linkage.angle_max_deg - 2.0, m, act) for m in PUSH_MOVES[:1]]
    assert all(m.push_v == act.motor.supply_v for m in moves)
    (df,) = run_trials(PlantConfig(actuator=act), moves, seed=1)
    assert df["force_n"].max() >= moves[0].peak_n and df["t_s"].iloc[-1] < TRIAL_CAP_S * pace(act)


MICRO = Path(__file__).parents[1] / "examples" / "actuators" / "micro_6v.toml"


def test_retracts_are_raised_on_a_slow_design_like_the_pushes():
    """Retracts are scaled like the pushes: unchanged on the paper's actuator and the shipped example; on
    micro_6v (whose pushes already run at the supply) raised to the supply, where the paper's stall force
    per volt left them at 0.6-0.9 of it (its data had 45 % of their contact rows unloading, the paper's
    17 %: a static surface fit of them sat between the two friction branches)."""
    from seagen.data.protocol import PUSH_MOVES, VALIDATION_MOVES, force_scale, scaled_move, volts_scale

    for act in (default_actuator(), load_actuator(EXAMPLE_ACTUATOR)):
        f = volts_scale(act) * force_scale(act)
        for move in PUSH_MOVES + VALIDATION_MOVES:
            assert scaled_move(20.0, move, act).retract_v == max(move[2] * f, -act.motor.supply_v)
    act = load_actuator(MICRO)
    moves = [scaled_move(act.linkage.angle_max_deg - 2.0, m, act) for m in PUSH_MOVES + VALIDATION_MOVES]
    assert all(m.retract_v == -act.motor.supply_v for m in moves)


@pytest.mark.slow  # ~5-18 s: a micro_6v trial at the plant's 1 ms step
def test_a_raised_retract_unloads_within_its_estimate_and_the_trial():
    """On micro_6v the quickest push's retract (at the supply) unloads the spring within the paced trial
    cap, in at most the estimate (reach.retract_time: the plant's retract friction is lower; scaled to the
    plant's whole deflection, spring and structure) and at least half of it."""
    from seagen.data.protocol import PUSH_MOVES, scaled_move, trial_cap_s
    from seagen.data.reach import retract_time

    act = load_actuator(MICRO)
    m = scaled_move(act.linkage.angle_max_deg - 2.0, PUSH_MOVES[3], act)
    (df,) = run_trials(PlantConfig(actuator=act), [m], seed=1)
    top = int(df["force_n"].idxmax())
    assert df["force_n"].iloc[top] >= m.peak_n and df["force_n"].iloc[-1] < 0.4
    t_back = float(df["t_s"].iloc[-1] - df["t_s"].iloc[top])
    # The estimate unloads the spring alone; the plant unloads its structure too (series_compliance, at the
    # design's scale since 18e1b86: on micro_6v 14.3 N/mm and beta 0.010 mm/N^2), so the time scales with the
    # whole deflection at the peak over the spring's.
    sc, f = PlantConfig(actuator=act).effects.series_compliance, float(df["force_n"].iloc[top])
    spring = f / act.stiffness_n_per_mm
    est = (
        retract_time(act, m.retract_v, m.peak_n)
        * (spring + f / sc.k_n_per_mm + sc.beta_mm_per_n2 * f**2)
        / spring
    )
    assert 0.5 * est <= t_back <= est and df["t_s"].iloc[-1] < trial_cap_s(act)
