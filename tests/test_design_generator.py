"""Designs drawn across the description's accepted ranges (hypothesis, derandomized): each is refused at the
description with its reason, or its calibration protocol reaches its force range and the short pipeline
(tune -> data generate -> train -> closed loop) gives usable data, finite metrics and a loop that settles."""

from __future__ import annotations

import copy
import functools
import math
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from seagen.actuator import Actuator, actuator_from_dict, default_actuator
from seagen.control.tune import hold_problem
from seagen.data.protocol import PUSH_MOVES, TRIAL_CAP_S, VALIDATION_MOVES, scaled_move
from seagen.data.reach import pace, push_time, reach_problem, retract_time
from seagen.errors import UserError
from seagen.runtime.control import ControlConfig, act_q


def _log(lo: float, hi: float) -> st.SearchStrategy[float]:
    """A float spread evenly in log between lo and hi (3 significant digits)."""
    return st.floats(math.log(lo), math.log(hi)).map(lambda x: float(f"{math.exp(x):.3g}"))


@st.composite
def designs(draw) -> dict:
    """A linear SEA description (the file's layout) with every field a compact SEA might have: the motor,
    the transmission, the spring, the linkage's lever, the pot, the loop rate and the force range."""
    d = default_actuator().to_dict()
    d["name"] = "drawn design"
    stall = draw(_log(30.0, 400.0))
    d["motor"].update(
        supply_v=draw(st.sampled_from([3.7, 6.0, 7.4, 12.0, 24.0, 48.0])),
        no_load_rpm=draw(_log(3000.0, 40000.0)),
        gear_ratio=draw(_log(4.0, 1000.0)),
        counts_per_rev=draw(st.sampled_from([3, 6, 12, 16, 64, 256, 1024, 4096])),
        stall_force_n=stall,
        time_constant_s=draw(_log(0.003, 0.03)),
    )
    d["transmission"].update(lead_mm=draw(_log(0.5, 12.0)), friction_n=draw(_log(0.5, 5.0)))
    d["spring"]["stiffness_n_per_mm"] = draw(_log(1.0, 20.0))
    d["linkage"]["cb_mm"] = draw(_log(25.0, 50.0))
    d["pot"].update(full_scale_deg=draw(_log(40.0, 300.0)), adc_bits=draw(st.sampled_from([10, 12, 14])))
    d["control"].update(
        loop_hz=draw(st.sampled_from([100.0, 200.0, 250.0, 500.0])),
        force_max_n=draw(_log(5.0, max(6.0, min(0.6 * stall, 80.0)))),
    )
    return d


def judged(d: dict) -> tuple[Actuator | None, str | None]:
    """(the description, None) when accepted; (None, the reason) when refused where a description is
    given: the loader's checks, the C's fixed-point formats and gains, the protocol's reach, the force
    loop's resolution (a pot step within the settling band)."""
    try:
        act = actuator_from_dict(d, "drawn.toml")
        ControlConfig.for_act(act_q(act))
    except UserError as e:
        return None, str(e)
    problem = reach_problem(act) or hold_problem(act)
    return (None, problem) if problem else (act, None)


def _check_accepted(act) -> None:
    """The protocol on an accepted design: pushes within the supply, each push's estimated time to its peak
    (a lower bound of the simulated push, within 2x: test_reach) fitting twice within the paced trial cap,
    and so does its retract's (reach.retract_time, raised like the pushes)."""
    cap = TRIAL_CAP_S * pace(act)
    for move in PUSH_MOVES + VALIDATION_MOVES:
        m = scaled_move(act.linkage.angle_max_deg - 2.0, move, act)
        assert 0 < m.push_v <= act.motor.supply_v and -act.motor.supply_v <= m.retract_v < 0
        assert 2.0 * push_time(act, m.push_v, m.peak_n) <= cap, (act.to_dict(), move)
        assert 2.0 * retract_time(act, m.retract_v, m.peak_n) <= cap, (act.to_dict(), move)


def test_drawn_designs_are_refused_with_a_reason_or_get_a_protocol_that_reaches_their_range():
    """Of 120 drawn designs at least 70 % are accepted; every refusal names the field to change; on every
    accepted one the protocol reaches its range in time (_check_accepted)."""
    seen: list[tuple[bool, float]] = []

    @settings(derandomize=True, max_examples=120, deadline=None, suppress_health_check=list(HealthCheck))
    @given(designs())
    def check(d: dict) -> None:
        act, why = judged(d)
        if act is None:
            assert why and any(f"{t}." in why for t in ("motor", "control", "spring", "pot", "linkage")), why
        else:
            _check_accepted(act)
        seen.append((act is not None, pace(act) if act is not None else math.nan))

    check()
    accepted = [p for ok, p in seen if ok]
    assert len(seen) >= 100 and len(accepted) >= 0.7 * len(seen), (len(accepted), len(seen))
    assert max(accepted) > 1.5  # the draw holds designs slower than the paper's, whose protocol is paced


def _pipeline(d: dict, tmp: Path, run_cli) -> dict:
    """tune (kin_mcu, its [control] lines pasted) -> data generate -> train SF -> simulate the model."""
    import json
    import tomllib

    from seagen.actuator import load_actuator

    f = tmp / "design.toml"
    f.write_text(tomli_w.dumps(d))
    code, out, err = run_cli("tune", "--actuator", str(f), "--trials", "3", "--seeds", "1", "--json")
    assert code == 0, err
    d["control"].update(tomllib.loads(json.loads(out)["control"]))
    f.write_text(tomli_w.dumps(d))
    code, _, err = run_cli("data", "generate", "--actuator", str(f), "--out", str(tmp / "data"))
    assert code == 0, err  # the coverage check passed: 75 % of the range in every split
    for task in ("calibration", "control"):
        args = [
            "--data",
            str(tmp / "data"),
            "--model",
            "sf",
            "--task",
            task,
            "--out",
            str(tmp / f"{task}.pt"),
        ]
        # the control SF with the paper's MAE loss: it follows the loading branch, where the loop ends
        # (least squares sits between the branches of the friction loop: docs/actuator.md)
        code, _, err = run_cli("train", *args, *(["--loss", "mae"] if task == "control" else []))
        assert code == 0, err
    code, out, err = run_cli("simulate", "--model", str(tmp / "control.pt"), "--seeds", "1", "--json")
    assert code == 0, err
    act = load_actuator(f)
    return {"act": act, "table": json.loads(out)}


# Accepted draws of the slow test (drawn(6)) whose SF loop does not settle at every target yet, by (supply V,
# stall N, force_max_n, spring N/mm): what it did (2026-11-27; MAE SF, tune 3 trials x 1 seed) and what is
# known of why. Strict: a draw listed here that settles fails the test, so the list shrinks.
UNSETTLED = {
    (12.0, 66.7, 8.53, 20.0): "1 / 0 / 0 of 10, 0.44 / 0.50 / 1.02 N off at steady levels, not at the "
    "command limit: an 8.53 N range on a 20 N/mm spring (0.43 mm in all, the +-0.3 N band 0.015 mm), the "
    "SF's map 0.022-0.051 mm off; its reading steps 0.07 N",
}


@functools.cache
def drawn(n: int) -> tuple[dict, ...]:
    """`n` designs drawn (hypothesis, derandomized) before any is run: the same on every run, whatever the
    pipeline does with them (drawn inside a test that runs it, they changed with its outcomes and timing)."""
    out: list[dict] = []

    @settings(derandomize=True, max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(designs())
    def draw(d: dict) -> None:
        out.append(d)

    draw()
    return tuple(out[:n])


@pytest.mark.slow
@pytest.mark.parametrize("k", range(6))
def test_accepted_designs_get_data_a_model_and_a_loop_that_settles(k, tmp_path):
    """Each accepted drawn design (drawn(6)): tuned gains, data that pass the coverage check (75 % of
    force_max_n in every split), an SF control model (MAE) with finite metrics, and its closed loop on the
    simulated design settling within the experiment's +-0.3 N band of the target at 25, 50 and 75 % of
    force_max_n: at least 9 of the 10 contact angles, under 0.3 N off on average (as
    tests/test_shipped_sf_loop.py asks of the shipped designs); the draws in UNSETTLED as measured there (a
    steady level, not yet the band)."""
    from seagen.control.experiment import BAND_N
    from seagen.modelfile import load_model
    from tests.conftest import run_cli

    d = copy.deepcopy(drawn(6)[k])
    act, why = judged(d)
    if act is None:
        assert why
        return
    tmp = tmp_path
    got = _pipeline(d, tmp, run_cli)
    model = load_model(tmp / "control.pt")
    assert all(math.isfinite(v) for m in model["metrics"].values() for v in m.values())
    (rows,) = [v for k, v in got["table"].items() if k.endswith("_mcu")]
    assert len(rows) == 3
    ok = {t: row["settled"] >= 0.9 * row["angles"] and row["error_avg_n"] < BAND_N for t, row in rows.items()}
    m, c = d["motor"], d["control"]
    known = UNSETTLED.get(
        (m["supply_v"], m["stall_force_n"], c["force_max_n"], d["spring"]["stiffness_n_per_mm"])
    )
    if known:  # still as measured: it reaches a steady level, not the band at every target
        assert not all(ok.values()), ("settles now: remove it from UNSETTLED", known, rows)
        assert all(row["settling_final_s"] is not None for row in rows.values()), (known, rows)
    else:
        assert all(ok.values()), (d, rows)


@pytest.mark.slow
@settings(derandomize=True, max_examples=4, deadline=None, suppress_health_check=list(HealthCheck))
@given(d=designs())
def test_discrepancy_on_accepted_drawn_designs(d):
    """On each accepted drawn design (quick protocol data of the design's own simulated plant): nothing
    hidden is left alone (verdict none), a hidden backlash is named first and claimed, and a structure
    stiffness mis-set x0.7 in the base is recalibrated within 5 % of the truth."""
    from seagen.discrepancy.bench import make_case, measure
    from seagen.discrepancy.workflow import identify
    from seagen.plant import PlantConfig

    act, why = judged(d)
    if act is None:
        assert why
        return
    truth = PlantConfig(actuator=act)
    res = identify(measure(truth, seed=5, fast=True), truth)
    assert res.verdict == "none" and not res.effects and not res.recalibrated, (act.to_dict(), res.verdict)

    case = make_case(("backlash",), 5, fast=True, act=act)
    res = identify(case.runs, case.base)
    names = [n.name for n in res.effects]
    assert names[:1] == ["backlash"] and res.effects[0].confidence >= 0.9, (act.to_dict(), case.hidden, names)

    k = float(truth.effect("series_compliance").k_n_per_mm)
    base = truth.with_effect("series_compliance", True, k_n_per_mm=0.7 * k)
    res = identify(measure(truth, seed=6, fast=True), base)
    fitted = {n.name: n.params for n in res.recalibrated}
    got = fitted.get("series_compliance", {}).get("k_n_per_mm", 0.7 * k)
    added = [n.name for n in res.effects]
    assert abs(got - k) <= 0.05 * k and not added, (act.to_dict(), got, k, added)


def _corner() -> dict:
    """The discrepancy test's first derandomized draw, near every range's low end (where shrinking goes too):
    3.7 V, 3,000 rpm, 4:1, 3 counts, 30 N stall, 1 mm lead, 1 N/mm spring, a 5 N range."""
    d = default_actuator().to_dict()
    d["name"] = "drawn design"
    d["motor"].update(
        supply_v=3.7,
        no_load_rpm=3000.0,
        gear_ratio=4.0,
        counts_per_rev=3,
        stall_force_n=30.0,
        time_constant_s=0.003,
    )
    d["transmission"].update(lead_mm=1.0, friction_n=1.0)
    d["spring"]["stiffness_n_per_mm"] = 1.0
    d["linkage"]["cb_mm"] = 25.0
    d["pot"].update(full_scale_deg=40.0, adc_bits=10)
    d["control"].update(loop_hz=100.0, force_max_n=5.0)
    return d


@pytest.mark.slow  # ~20-40 s: three quick-protocol discrepancy runs
def test_misset_stiffness_on_the_corner_draw_is_deterministic_and_recovered():
    """The misset-stiffness case on the corner draw gives bit-identical results run first and after another
    design's run in the same process (np.array_equal), and recovers the structure within 5 %. Its structure
    is at the design's scale (30 / 4.2 times its 1 N/mm spring): with the paper's absolute 30 N/mm it was 3 %
    of the deflection and the recovered value moved 31.4 -> 32.7 N/mm with a change of retract volts alone."""
    import numpy as np

    from seagen.discrepancy.bench import measure
    from seagen.discrepancy.workflow import identify
    from seagen.plant import PlantConfig

    def misset(act) -> dict:
        truth = PlantConfig(actuator=act)
        k = float(truth.effect("series_compliance").k_n_per_mm)  # type: ignore[attr-defined]
        base = truth.with_effect("series_compliance", True, k_n_per_mm=0.7 * k)
        res = identify(measure(truth, seed=6, fast=True), base)
        return {"k": k, **{f"{n.name}.{p}": v for n in res.recalibrated for p, v in n.params.items()}}

    act, why = judged(_corner())
    assert act is not None, why
    first = misset(act)
    # another accepted design (3.63 N/mm, as first written, is now refused: one encoder count is 0.30 N)
    other_act, why = judged(dict(_corner(), spring={"stiffness_n_per_mm": 1.8}))
    assert other_act is not None, why
    misset(other_act)
    again = misset(act)
    assert first.keys() == again.keys()
    assert all(np.array_equal(first[key], again[key]) for key in first)
    got = first.get("series_compliance.k_n_per_mm", 0.7 * first["k"])
    assert abs(got - first["k"]) <= 0.05 * first["k"], first
