"""Hidden-effect cases: the workflow, started from a base without the effect, names it (issue 6 item 2)."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.data import protocol
from seagen.discrepancy.bench import HARD_PAIRS, HIDEABLE, make_case, measure
from seagen.discrepancy.workflow import identify
from seagen.plant import Plant, PlantConfig, pick

FAST_SEED = 11
SLOW_SEEDS = (21, 31)
# The fast suite (`make test`) runs each behaviour once on quick data (bench.FAST_MOVES: brisk moves, a
# data set costs about half); the effects in COVERED_ELSEWHERE are named first by another fast test. The
# slow suite runs the same behaviours on the benchmark's protocol data and more seeds.
COVERED_ELSEWHERE = {
    "spring_preload": "test_discrepancy.py::test_cli_names_adds_and_reports",
    "load_cell_offset": "test_two_hidden_effects_are_both_found",
    "transport_delay": "test_hard_pair_members_are_told_apart[transport_delay-not-pot_voltage_drop]",
}
FAST_MEMBER = ("transport_delay", "pot_voltage_drop")
# To keep the fast suite's discrepancy tests short (<= 90 s on 2 cores), the single-effect sweep runs fast
# only on a sensor-side effect (pot_voltage_drop); the others (and viscous_friction in a pair:
# test_two_hidden_effects_with_viscous_friction) are named in the slow suite (quick data here,
# and protocol data with three seeds: test_single_hidden_effect_more_seeds). series_compliance is still
# named first in the fast suite as the closest form (test_effect_in_another_form_is_named_as_closest), and
# backlash is ranked first by signature (test_discrepancy_signature.py).
SWEEP_SLOW = {
    "actuator_friction",
    "linkage_friction",
    "stribeck_friction",
    "spring_nonlinearity",
    "series_compliance",
    "backlash",
    "viscous_friction",
}


def _check_single(effect: str, seed: int, fast: bool) -> None:
    """One hidden effect: named first, with the residual brought to the noise floor."""
    case = make_case((effect,), seed, fast=fast)
    res = identify(case.runs, case.base)
    names = [n.name for n in res.effects]
    assert names and names[0] == effect, f"hidden {effect} {case.hidden}, named {names}"
    assert res.rms_after <= 1.2 * res.noise_floor, f"{effect}: {res.rms_after} vs floor {res.noise_floor}"
    assert res.effects[0].confidence >= 0.8


@pytest.mark.parametrize(
    "effect",
    [
        pytest.param(e, marks=(pytest.mark.slow,) if e in COVERED_ELSEWHERE or e in SWEEP_SLOW else ())
        for e in HIDEABLE
    ],
)
def test_single_hidden_effect_is_named(effect: str) -> None:
    """Every catalogue effect but pot_noise, hidden with random realistic parameters in quick data, is
    named first (7-20 s each; the ones named by another fast test and the SWEEP_SLOW ones are slow here)."""
    _check_single(effect, FAST_SEED, fast=True)


@pytest.mark.slow
@pytest.mark.parametrize("seed", (FAST_SEED, *SLOW_SEEDS))
@pytest.mark.parametrize("effect", HIDEABLE)
def test_single_hidden_effect_more_seeds(effect: str, seed: int) -> None:
    """The same on the benchmark's protocol data and more seeds (other parameters, other noise)."""
    _check_single(effect, seed, fast=False)


@pytest.mark.parametrize(
    "seed, fast", [(FAST_SEED, True), pytest.param(SLOW_SEEDS[0], False, marks=pytest.mark.slow)]
)
def test_nothing_hidden_answers_none(seed: int, fast: bool) -> None:
    """The control: data from the base plant itself gives `none` and no effect (~1 s)."""
    runs = measure(PlantConfig(), seed=seed, fast=fast)
    res = identify(runs, PlantConfig())
    assert res.verdict == "none" and res.effects == []


def _check_pair(pair: tuple[str, str], seed: int, fast: bool = False) -> None:
    """Two effects hidden at once: both are named (in turn or as a pair)."""
    case = make_case(pair, seed, fast=fast)
    res = identify(case.runs, case.base)
    names = {n.name for n in res.effects}
    assert set(pair) <= names, f"hidden {case.hidden}, named {names}"
    assert res.rms_after <= 1.2 * res.noise_floor


def test_two_hidden_effects_are_both_found() -> None:
    """A spring preload and a load-cell offset hidden together in quick data: both found (~20 s)."""
    _check_pair(("load_cell_offset", "spring_preload"), FAST_SEED, fast=True)


@pytest.mark.slow
def test_two_hidden_effects_with_viscous_friction() -> None:
    """Viscous friction and a load-cell offset hidden together in quick data: both found (~40 s; the fast
    suite's pair was this one until a cheaper pair took its place)."""
    _check_pair(("viscous_friction", "load_cell_offset"), FAST_SEED, fast=True)


@pytest.mark.slow
@pytest.mark.parametrize("pair", HARD_PAIRS)
def test_hard_pairs_hidden_together(pair: tuple[str, str]) -> None:
    """The hard-to-separate pairs of DESIGN.md §3 hidden together: both found."""
    _check_pair(pair, FAST_SEED)


@pytest.mark.slow
@pytest.mark.parametrize(
    "hidden, seed", [(("stribeck_friction",), 103), (("series_compliance", "spring_nonlinearity"), 160)]
)
def test_bench_regressions(hidden: tuple[str, ...], seed: int) -> None:
    """Bench cases that once failed: stick-slip (a stepped objective) and compliance with a progressive
    spring (narrow valley, the pair needs its own search)."""
    if len(hidden) == 1:
        _check_single(hidden[0], seed, fast=False)
    else:
        _check_pair(hidden, seed)


def _member_cases() -> list:
    """Both directions of every hard pair; one (FAST_MEMBER, quick data) in the fast suite."""
    out = []
    for a, b in HARD_PAIRS:
        for hidden, partner in ((a, b), (b, a)):
            fast = (hidden, partner) == FAST_MEMBER
            marks = () if fast else (pytest.mark.slow,)
            out.append(pytest.param(hidden, partner, fast, marks=marks, id=f"{hidden}-not-{partner}"))
    return out


@pytest.mark.parametrize("hidden, partner, fast", _member_cases())
def test_hard_pair_members_are_told_apart(hidden: str, partner: str, fast: bool) -> None:
    """One member of a hard pair hidden, the other a candidate too: the hidden one is named, not the other
    (~8 s for the fast one)."""
    default = PlantConfig().with_effect(partner, False)
    case = make_case((hidden,), FAST_SEED + 1, default=default, fast=fast)
    res = identify(case.runs, case.base)
    names = [n.name for n in res.effects]
    assert names and names[0] == hidden and partner not in names, f"hidden {case.hidden}, named {names}"


class LuGrePlant(Plant):
    """Steady-state LuGre friction, not the catalogue's form: (Fc + (Fs-Fc) e^{-|v|/vs}) + s2 |v|."""

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Velocity-shaped band, symmetric, on top of the plant's other friction."""
        fwd, rev = super().friction_limits(angle_deg)
        v = np.abs(getattr(self, "v_shaft", np.zeros_like(fwd)))
        g = 2.2 + 0.9 * np.exp(-v / 0.8) + 0.02 * v
        return fwd + g, rev + g


class CubicCompliancePlant(Plant):
    """Structure deflection d = F/k + g F^3 (the catalogue uses F/k + beta F^2)."""

    def structure_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Invert d(F) by Newton on each element; slope from the inverse derivative (elements idx)."""
        yc = pick(self.y_contact, idx)
        d = np.maximum(y - yc, 0.0)
        k, g = 35.0, 2.5e-4
        f = np.minimum(d * k, np.cbrt(d / g))
        for _ in range(30):
            f = np.maximum(f - (f / k + g * f**3 - d) / (1 / k + 3 * g * f**2), 0.0)
        return f, np.where(y > yc, 1.0 / (1 / k + 3 * g * f**2), 0.0)


LUGRE = (LuGrePlant, "actuator_friction", {"actuator_friction", "stribeck_friction"})
CUBIC = (CubicCompliancePlant, "series_compliance", {"series_compliance"})


@pytest.mark.parametrize(
    "plant_cls, removed, expected, fast",
    [
        (*CUBIC, True),
        pytest.param(*LUGRE, True, marks=pytest.mark.slow),
        pytest.param(*LUGRE, False, marks=pytest.mark.slow),
        pytest.param(*CUBIC, False, marks=pytest.mark.slow),
    ],
)
def test_effect_in_another_form_is_named_as_closest(monkeypatch, plant_cls, removed, expected, fast) -> None:
    """Data from a plant whose effect has a non-catalogue form: the closest catalogue effect is named first
    and ranked first by signature; a learned remainder never makes the held-out fit worse (fast: quick
    data and one naming round, ~25 s; slow: protocol data, every round)."""
    monkeypatch.setattr(protocol, "Plant", plant_cls)
    truth = PlantConfig().with_effect(removed, False)
    runs = measure(truth, seed=5, fast=fast)
    monkeypatch.undo()
    res = identify(runs, truth, max_rounds=1 if fast else 3)
    names = [n.name for n in res.effects]
    assert names and names[0] in expected, f"named {names}"
    assert res.ranking[0][0] in expected, res.ranking[:3]
    assert res.rms_after < 0.5 * res.rms_before and res.rms_learned <= res.rms_after
