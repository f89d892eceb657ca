"""`seagen discrepancy bench --actuator FILE`: the cases simulate that design and its rig logs are imported
with it; a description that cannot be read is refused (exit 2, naming the file)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from seagen.actuator import default_actuator, load_actuator
from seagen.cli import main
from seagen.data.protocol import volts_scale
from seagen.discrepancy import bench as dbench
from seagen.discrepancy import rigbench
from tests.conftest import EXAMPLE_ACTUATOR as STIFF


def test_case_angles_come_from_the_linkage_range() -> None:
    """The paper's six case angles are kept; a narrower linkage range moves them inside it."""
    assert dbench.case_angles() == (6.0, 10.0, 14.0, 18.0, 22.0, 26.0)
    act = default_actuator()
    narrow = dataclasses.replace(
        act, linkage=dataclasses.replace(act.linkage, angle_min_deg=8.0, angle_max_deg=20.0, split_deg=14.0)
    )
    angles = dbench.case_angles(narrow)
    assert angles[0] == 9.0 and angles[-1] == 18.0 and len(angles) == 6
    assert {m.angle_deg for m in dbench.case_moves(act=narrow)} == set(angles)


def test_default_mode_cases_run_on_the_given_design() -> None:
    """A case of `bench --actuator` simulates that design: its base carries it, rows at its loop rate."""
    act = load_actuator(STIFF)
    case = dbench.make_case(("backlash",), 3, fast=True, act=act)
    assert case.base.actuator == act
    dt = np.diff(case.runs.t[0][case.runs.mask[0]])
    assert np.allclose(dt, 1.0 / act.loop_hz)


def test_rig_bench_on_the_second_design_leaves_nothing_hidden_alone(monkeypatch, capsys) -> None:
    """`bench --rig --quick --actuator stiff_24v.toml` (two of its nothing-hidden cases, 200 Hz, both
    conventions and both dialects; ~5 s): logs written in % of the 24 V supply and imported with that
    actuator, verdict none, nothing added or recalibrated, the command timing found."""
    seen = []
    real_import = rigbench.import_log

    def spy(log, mapping, act=None):
        seen.append(act)
        return real_import(log, mapping, act)

    full = rigbench.plan
    monkeypatch.setattr(rigbench, "plan", lambda seeds: [c for c in full(seeds) if c[0] == "control"][:2])
    monkeypatch.setattr(rigbench, "import_log", spy)
    args = ["discrepancy", "bench", "--rig", "--quick", "--seeds", "1", "--jobs", "1", "--json"]
    assert main([*args, "--actuator", str(STIFF)]) == 0
    out = json.loads(capsys.readouterr().out)
    act = load_actuator(STIFF)
    assert out["actuator"] == act.name and seen == [act, act]
    assert [c["dialect"] for c in out["cases"]] == [0, 1]
    assert out["control_untouched_rate"] == 1.0, out["cases"]
    assert out["lag_found_rate"] == 1.0, out["cases"]


@pytest.mark.parametrize("flags", [[], ["--rig"], ["--families"]])
def test_bad_actuator_exits_2_naming_the_file(tmp_path, capsys, flags) -> None:
    """A description that cannot be used stops the bench before any case runs."""
    bad = tmp_path / "bad.toml"
    bad.write_text(STIFF.read_text().replace("stiffness_n_per_mm = 8.4", "stiffness_n_per_mm = -8.4"))
    assert main(["discrepancy", "bench", *flags, "--seeds", "1", "--actuator", str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "stiffness_n_per_mm" in err and "Traceback" not in err
    missing = tmp_path / "none.toml"
    assert main(["discrepancy", "bench", *flags, "--actuator", str(missing)]) == 2
    assert str(missing) in capsys.readouterr().err


def test_moves_reach_their_peak_on_both_designs() -> None:
    """The reduced protocol's pushes are scaled to the motor (the paper's stall force per volt; exactly the
    paper's volts on its own actuator): on both shipped designs every push reaches its peak force and the
    trial ends well before the 8 s cap (unscaled, stiff_24v's 2.5-3 V pushes stalled below 17-19 N at
    22-26 deg and crept at stall to the cap)."""
    from seagen.plant import PlantConfig

    assert volts_scale() == 1.0
    paper = dbench.case_moves()
    assert [(m.push_v, m.retract_v) for m in paper] == [
        (dbench.PUSH_MOVES[(i + k) % 5][0], dbench.PUSH_MOVES[(i + k) % 5][2])
        for i in range(6)
        for k in (0, 1)
    ]
    for act in (default_actuator(), load_actuator(STIFF)):
        m = act.motor
        moves = dbench.case_moves(act=act)
        for mv, ref in zip(moves, paper, strict=True):  # the same stall force at each push
            assert mv.push_v * m.stall_force_n / m.supply_v == pytest.approx(ref.push_v * 150.0 / 12.0)
        for mv, df in zip(moves, dbench.case_frames(PlantConfig(actuator=act), seed=1), strict=True):
            assert df.force_n.max() >= mv.peak_n and df.t_s.iloc[-1] < 4.0, (act.name, mv)


def test_replay_holds_a_switch_on_a_float_rounded_step_edge_exactly() -> None:
    """Logged times summed in floating point (a simulator's t += dt) put a switch 1e-18 s off a plant step's
    edge: the drive holds the command exactly there (it used to give a time-weighted mean with ~1e-9 V of
    cancellation error, which a stick-slip plant turns into encoder counts); a switch really inside a step
    still gets the time-weighted mean."""
    from seagen.discrepancy.replay import CHANNELS, Runs, drive

    t, times = 0.0, []
    for _ in range(400):  # rows every 5 ms, the time summed as the simulator does
        times.append(t)
        for _ in range(5):
            t += 1e-3
    times_a = np.array(times)
    assert not np.array_equal(times_a, np.arange(400) * 5e-3)  # rounding is there
    volts = np.where((np.arange(400) // 7) % 2 == 0, 3.0, -5.5)
    mask = np.ones((1, 400), dtype=bool)
    meas = {c: np.zeros((1, 400)) for c in CHANNELS}
    runs = Runs(
        np.array([10.0]), volts[None, :], meas, mask, ["a"], times_a[None, :], np.ones(1), np.zeros(1)
    )
    u = drive(runs, 1e-3)
    assert np.array_equal(u[0, : 5 * 399], np.repeat(volts[1:], 5))  # command j held over (t_{j-1}, t_j]
    half = Runs(
        np.array([10.0]), volts[None, :], meas, mask, ["a"], times_a[None, :], np.full(1, 0.1), np.zeros(1)
    )
    v = drive(half, 1e-3)[0]  # switches 0.5 ms into a step: that step gets the mean of the two commands
    k = 7 * 5 - 1  # row 7's command (the first -5.5 V) takes effect at 35 - 0.5 ms
    assert v[k - 1] == 3.0 and v[k + 1] == -5.5 and v[k] == pytest.approx((3.0 - 5.5) / 2)


def test_cases_picks_a_subset_and_refuses_unknown_names(capsys) -> None:
    """`bench --cases` runs only the named cases (a hidden effect, a kind); an unknown name exits 2."""
    assert dbench.chosen(("single", ("backlash",), 5), ("backlash",))
    assert dbench.chosen(("pair", ("backlash", "stribeck_friction"), 70), ("stribeck_friction",))
    assert dbench.chosen(("control", (), 50), ("control",))
    assert not dbench.chosen(("single", ("spring_preload",), 6), ("backlash", "pair"))
    assert dbench.chosen(("single", ("spring_preload",), 6))
    for flags in ([], ["--rig"], ["--families"]):
        assert main(["discrepancy", "bench", *flags, "--seeds", "1", "--cases", "backlash,nonsense"]) == 2
        err = capsys.readouterr().err
        assert "nonsense" in err and "Traceback" not in err


@pytest.mark.slow
@pytest.mark.parametrize(
    "effect",
    [
        "actuator_friction",
        "stribeck_friction",  # was a strict xfail (one erratic trial left out) until the structure was at
        # stiff_24v's scale (60 N/mm, 18e1b86): now explained at the floor over all six held-out trials
        "series_compliance",
    ],
)
def test_fine_encoder_single_cases_end_explained(effect: str) -> None:
    """The three single cases of `bench --seeds 1 --actuator stiff_24v.toml` that ended `unexplained` with
    extra effects (stall creep to the time cap, a float sliver in the replayed command, the command lag
    pulled to 0.98 by the missing compliance) name only the hidden effect and reach the noise floor
    (~30-45 s of CPU each)."""
    from seagen.plant.config import CATALOGUE

    row = dbench.run_case("single", (effect,), CATALOGUE.index(effect), act=load_actuator(STIFF))
    assert row["named"] == effect and row["recalibrated"] == "-", row
    assert row["verdict"] == "explained" and row["rms_after"] <= 1.1 * row["noise_floor"], row


def test_own_logs_pin_the_command_timing_on_the_fine_encoder() -> None:
    """seagen's own logs declare their command timing (up_to_row) and the replay pins it: the stiff design's
    series compliance + spring nonlinearity pair (bench --seeds 3's seed 160) is named and explained. With
    the lag fitted on the base it came out 0.98 (the missing compliance pulls it), which on this encoder
    (61 nm a count) replays the truth 1,200x above the noise, and the pair search named a Stribeck friction
    instead (~10 s)."""
    case = dbench.make_case(("series_compliance", "spring_nonlinearity"), 160, act=load_actuator(STIFF))
    assert case.runs.declared == 1.0
    res = dbench.identify(case.runs, case.base)
    assert res.timing.pinned == 1.0 and res.timing.lag == 1.0
    named = {n.name for n in res.effects} | {n.name for n in res.recalibrated}
    assert named == {"series_compliance", "spring_nonlinearity"}, named
    assert res.verdict == "explained"


def test_undeclared_timing_is_fitted_again_once_physics_is_named() -> None:
    """The same kind of data without a declared timing (a log that does not say): the lag fitted with the
    base lacking the compliance is off, and once the compliance is named it is fitted again with it, said in
    the notes, and ends at seagen's convention (lag 1) with only the hidden effect (~15 s). Seed 1: since
    the structure's draws are at the design's scale (18e1b86) seed 4's compliance no longer pulls the first
    lag off (of seeds 0-19, 1 and 19 do)."""
    case = dbench.make_case(("series_compliance",), 1, act=load_actuator(STIFF))
    runs = dataclasses.replace(case.runs, declared=None)
    res = dbench.identify(runs, case.base)
    assert res.timing.pinned is None and res.timing.lag == 1.0
    assert any(n.startswith("command timing re-fitted with series_compliance") for n in res.notes), res.notes
    assert [n.name for n in res.effects] == ["series_compliance"] and not res.recalibrated


def test_calibration_protocol_pushes_reach_their_peak_on_both_designs() -> None:
    """`data generate`'s pushes (and the friction measurement's) are scaled to the motor like the bench's:
    at the highest train angle every push of the calibration protocol reaches its peak force well before
    the cap on both designs (unscaled, the 24 V motor stalled below it), and on the paper's actuator the
    moves are its volts exactly."""
    from seagen.data.protocol import PUSH_MOVES, run_trials, scaled_move, train_angles
    from seagen.geometry import geometry
    from seagen.plant import PlantConfig

    assert [scaled_move(9.0, m) for m in PUSH_MOVES] == [dbench.Move(9.0, *m) for m in PUSH_MOVES]
    for act in (default_actuator(), load_actuator(STIFF)):
        top = train_angles(geometry(act))[-1]
        moves = [scaled_move(top, m, act) for m in PUSH_MOVES]
        for mv, df in zip(moves, run_trials(PlantConfig(actuator=act), moves, seed=2), strict=True):
            assert df.force_n.max() >= mv.peak_n and df.t_s.iloc[-1] < 4.0, (act.name, mv)
