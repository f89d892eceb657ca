"""Forms written apart from the naming rule (tests/apart_forms.py): their laws; the rule measured on them."""

from __future__ import annotations

import importlib

import numpy as np
import pytest
from apart_forms import FORMS, rates, run_form

from seagen.data.protocol import Move, run_trials
from seagen.plant import Plant
from seagen.plant.config import CATALOGUE

# One brisk push into the load cell and back at a low and a high contact angle (well under a second per form).
MOVES = [Move(8.0, 5.0, 15.0, -8.0), Move(22.0, 5.0, 15.0, -8.0)]
SETS = ("apart_forms", "apart_forms_b", "apart_forms_c", "apart_forms_d", "apart_forms_e")  # A, then B-E
NOISE = {"enc": 1.0, "pot": 10.0, "load_cell_n": 0.08}  # counts, counts, N: the plant's noise or resolution


def form_trials(form_case, name: str, moves: list[Move] = MOVES):
    """(form params, truth trials, base trials) of a form of the set whose `form_case` is given: the form's
    plant and the plain one, same config and seed (sets B-E's law checks)."""
    cls, cfg, params = form_case(name, 0)
    return params, run_trials(cfg, moves, seed=3, plant_cls=cls), run_trials(cfg, moves, seed=3)


def form_pair(form_case, name: str, angles: list[float]) -> tuple[Plant, Plant, dict[str, float]]:
    """(form plant, plain plant) on the form's config at `angles`, and the form's parameters (seed 0)."""
    cls, cfg, params = form_case(name, 0)
    return cls(cfg, np.array(angles), seed=1), Plant(cfg, np.array(angles), seed=1), params


def drive(plants: tuple[Plant, ...], volts: float, seconds: float) -> list[dict[str, np.ndarray]]:
    """Step each plant at constant volts (in turn, each step); per plant and step: compression, shaft,
    motor, nut, current (step x batch) (sets B-D's law checks)."""
    keys = ("d", "y", "motor", "nut", "current")
    out: list[dict[str, list[np.ndarray]]] = [{k: [] for k in keys} for _ in plants]
    for _ in range(int(round(seconds / plants[0].cfg.dt_s))):
        for p, o in zip(plants, out, strict=True):
            p.step(volts)
            now = (p.nut_mm - p.shaft_mm, p.shaft_mm, p.motor_mm, p.nut_mm, p.current)
            for k, v in zip(keys, now, strict=True):
                o[k].append(np.array(v, copy=True))
    return [{k: np.array(v) for k, v in o.items()} for o in out]


def _change(name: str, forms: str = "apart_forms") -> dict[str, float]:
    """Largest RMS change per channel (NOISE units) the form of set `forms` makes to the base plant's trials,
    same noise."""
    cls, cfg, _ = importlib.import_module(forms).form_case(name, 0)
    truth, base = run_trials(cfg, MOVES, seed=3, plant_cls=cls), run_trials(cfg, MOVES, seed=3)
    out = {}
    for c, sigma in NOISE.items():
        per = []
        for a, b in zip(truth, base, strict=True):
            n = min(len(a), len(b))
            per.append(float(np.sqrt(np.mean((a[c].to_numpy()[:n] - b[c].to_numpy()[:n]) ** 2))) / sigma)
        out[c] = max(per)
    return out


@pytest.mark.parametrize("forms", SETS)
def test_forms_are_well_formed(forms):
    """8-10 forms in each set, expected names from the catalogue, replaced effects switched off, at least one
    form no catalogue effect is close to; no form name in two sets."""
    mod = importlib.import_module(forms)
    assert 8 <= len(mod.FORMS) <= 10
    for name, form in mod.FORMS.items():
        assert form.expected <= set(CATALOGUE), name
        assert form.why
        if form.replaces:
            _, cfg, _ = mod.form_case(name, 0)
            assert not cfg.on(form.replaces), name
    assert any(not f.expected for f in mod.FORMS.values())
    names = [n for m in SETS for n in importlib.import_module(m).FORMS]
    assert len(names) == len(set(names))  # no form name in two sets


@pytest.mark.parametrize("forms", SETS[1:])
def test_other_sets_run_set_as_harness_and_leave_it_unchanged(forms):
    """Sets B-E run set A's harness (apart_forms.Harness) on their forms and put set A's forms back."""
    import apart_forms

    mod = importlib.import_module(forms)
    before, name = apart_forms.FORMS, list(mod.FORMS)[-1]
    cls, _, _ = mod.form_case(name, 0)
    assert apart_forms.FORMS is before and name not in before
    assert cls.__mro__[1] is mod.FORMS[name].cls
    assert mod.rates is apart_forms.rates and mod.HARNESS.forms is mod.FORMS


def _first_fast(cases: list) -> list:
    """The cases, all but the first of each set marked slow: the fast suite runs one form per set, `make
    test-slow` the sweep."""
    seen: set = set()
    out = []
    for c in cases:
        key = c[0] if isinstance(c, tuple) else None
        out.append(
            c
            if key not in seen
            else pytest.param(*(c if isinstance(c, tuple) else (c,)), marks=pytest.mark.slow)
        )
        seen.add(key)
    return out


@pytest.mark.parametrize("name", _first_fast(list(FORMS)))
def test_form_law_differs_from_base_above_noise(name):
    """Each form's plant runs, and its law moves some measured channel by more than twice the noise (RMS)."""
    change = _change(name)
    assert max(change.values()) > 2.0, change


OTHER_FORMS = [(m, n) for m in SETS[1:] for n in importlib.import_module(m).FORMS]


@pytest.mark.parametrize(("forms", "name"), _first_fast(OTHER_FORMS))
def test_other_sets_forms_move_a_channel_above_noise(forms, name):
    """Sets B-E: each form's plant runs through the protocol, and its law moves some measured channel by more
    than 1.5 noise units (RMS over set A's two brisk trials; the workflow's data hold twelve longer ones)."""
    change = _change(name, forms)
    assert max(change.values()) > 1.5, change


@pytest.mark.parametrize("forms", SETS)
def test_form_parameters_are_drawn_within_ranges(forms):
    """Parameters differ between seeds and stay in their stated ranges (both sets)."""
    mod = importlib.import_module(forms)
    for name, form in mod.FORMS.items():
        p0, p1 = mod.form_case(name, 0)[2], mod.form_case(name, 1)[2]
        assert p0 != p1
        for k, (lo, hi) in form.ranges.items():
            assert lo <= p0[k] <= hi and lo <= p1[k] <= hi


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="the naming rule misses the first goal on these forms (7/9 named first, also with the closest "
    "single change named first; wrong claims at >= 0.9 went 3/10 -> 0/10 with the evidence rule, tuned on "
    "them; docs/discrepancy.md): a known failure of the rule, kept as the check it must pass",
)
def test_naming_rule_on_forms_written_apart():
    """The issue's goal on forms not used to tune the rule: the closest effect named first in >= 90 % of the
    named cases, a wrong name claimed at >= 0.9 in <= 5 % of the cases (one seed per form)."""
    rows = [run_form(name, 0) for name in FORMS]
    k = rates(rows)
    assert k["closest_first_rate"] >= 0.9 and k["wrong_sure_rate"] <= 0.05, [
        (r["form"], r["first"], r["wrong_sure"]) for r in rows
    ]


@pytest.mark.slow
def test_naming_goal_on_the_sets_never_used_to_tune():
    """The issue's goal on the forms never used to tune the rule, the name given first or the search (sets D
    and E, each run once on the search it was first measured on, E on the final one): the closest effect
    named first in >= 90 % of the named cases, a wrong name claimed at >= 0.9 in <= 5 % (one seed each;
    about 8 min in one process). Set E alone: 8/9."""
    rows = [
        m.run_form(name, 0)
        for m in map(importlib.import_module, ("apart_forms_d", "apart_forms_e"))
        for name in m.FORMS
    ]
    k = rates(rows)
    assert k["closest_first_rate"] >= 0.9 and k["wrong_sure_rate"] <= 0.05, [
        (r["form"], r["first"], r["wrong_sure"]) for r in rows
    ]
