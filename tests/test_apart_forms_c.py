"""Set C of the forms written apart from the naming rule (tests/apart_forms_c.py): each law does what its
docstring says, without running the discrepancy workflow."""

from __future__ import annotations

from functools import partial

import apart_forms
import apart_forms_b
import numpy as np
import pytest
from apart_forms_c import FORMS, TRIAL_GAP_S, form_case, rates, run_form
from test_apart_forms import drive, form_pair, form_trials  # set A's moves and noise units

from seagen.data.protocol import Move
from seagen.plant import Plant

_trials = partial(form_trials, form_case)  # this set's forms
_pair = partial(form_pair, form_case)


def test_set_c_has_ten_new_forms():
    """Ten forms, seven or eight with an expected name, none named like a form of sets A or B."""
    assert len(FORMS) == 10
    assert 7 <= sum(bool(f.expected) for f in FORMS.values()) <= 8
    assert not set(FORMS) & (set(apart_forms.FORMS) | set(apart_forms_b.FORMS))
    assert not {f.cls for f in FORMS.values()} & {f.cls for f in apart_forms_b.FORMS.values()}


def test_return_spring_is_a_pull_of_one_sign_in_the_shaft_balance():
    """Sliding out in free motion the spring carries the friction band plus f_r + k_r y; sliding back it
    carries f_r + k_r y less the reverse band (the pull helps the retract, it does not flip)."""
    form, _, p = _pair("return_spring", [24.0])
    for volts, seconds in ((4.0, 0.3), (-6.0, 0.1)):
        a = drive((form,), volts, seconds)[0]
        y = a["y"][-1, 0]
        assert y > 0.5 and np.sign(a["y"][-1, 0] - a["y"][-2, 0]) == np.sign(volts)  # sliding
        fwd, rev = form.friction_limits(form.geo.angle_from_shaft(a["y"][-1]))
        band = fwd[0] if volts > 0 else -rev[0]
        pull = form.spring_force(a["d"][-1])[0] - band
        assert abs(pull - (p["f_r"] + p["k_r"] * y)) < 0.05, (pull, y)


def test_film_lag_friction_is_full_at_rest_and_fades_while_sliding():
    """At rest the band is the plant's plus dF; sliding steadily the film speed reaches |v| and the extra
    falls to dF / (1 + (v / v_s)^2)."""
    form, plain, p = _pair("film_lag_friction", [24.0])
    ang = np.array([10.0])
    assert np.allclose(form.friction_limits(ang)[0] - plain.friction_limits(ang)[0], p["df"])
    drive((form, plain), 4.0, 0.4)
    v = abs(form.v_shaft[0])
    assert v > 3 * p["v_s"] and abs(form._s[0] - v) < 0.1 * v
    extra = form.friction_limits(ang)[0] - plain.friction_limits(ang)[0]
    assert np.allclose(extra, p["df"] / (1 + (form._s / p["v_s"]) ** 2)) and extra[0] < 0.3 * p["df"]


def test_creeping_housing_deflects_further_the_longer_a_force_is_held():
    """Held in contact at a steady push, the creep deflection approaches F / k2 with time constant tau; the
    pot's angle is the plain plant's (the creep is beyond the pivot) while the motor travels further."""
    form, plain, p = _pair("creeping_housing", [10.0])
    a, b = drive((form, plain), 1.5, 4.0)  # stalls in contact near 1.5 / 12 x 150 N at the nut
    f = form.shaft_force[0]
    assert f > 5.0 and abs(form._x2[0] - f / p["k2"]) < 0.05 * f / p["k2"]
    assert a["motor"][-1, 0] > b["motor"][-1, 0] + 0.5 * f / p["k2"]
    assert np.array_equal(form.read().pot, plain.read().pot)


def test_ground_shift_pot_follows_the_signed_current():
    """Same state and noise: the pot differs by rint(kappa i (1 - x)): up while pushing, down retracting."""
    form, plain, p = _pair("ground_shift_pot", [24.0])
    for volts, sign in ((4.0, 1), (-7.0, -1)):
        drive((form, plain), volts, 0.02)
        s, t = form.read(), plain.read()
        shift = p["kappa"] * plain.current * (1 - t.pot / plain.geo.adc_max)
        assert np.array_equal(s.pot, np.rint(t.pot + shift).astype(np.int64))
        assert sign * (s.pot[0] - t.pot[0]) > 10


def test_cable_drag_is_a_step_in_the_linkage_angle():
    """The extra band is dF / (1 + exp(-(angle - theta_c) / w)) both ways: ~0 well below theta_c, ~dF
    above."""
    form, plain, p = _pair("cable_drag", [20.0])
    angles = np.array([5.0, p["theta_c"] - 5 * p["w"], p["theta_c"], p["theta_c"] + 5 * p["w"], 28.0])
    (f1, r1), (f0, r0) = form.friction_limits(angles), plain.friction_limits(angles)
    want = p["df"] / (1 + np.exp(-(angles - p["theta_c"]) / p["w"]))
    assert np.allclose(f1 - f0, want) and np.allclose(r1 - r0, want)
    assert want[1] < 0.01 * p["df"] and want[3] > 0.99 * p["df"] and np.isclose(want[2], p["df"] / 2)


def test_pot_coupling_play_lags_the_linkage_by_delta_both_ways():
    """Opening, the pot's shaft trails the linkage by delta; after the reversal it leads it back by delta."""
    form, _, p = _pair("pot_coupling_play", [26.0])
    drive((form,), 4.0, 0.25)
    assert np.isclose(form._linkage_angle()[0] - form._seen[0], p["delta"])
    drive((form,), -6.0, 0.4)
    assert np.isclose(form._seen[0] - form._linkage_angle()[0], p["delta"])


def test_dither_friction_lowers_the_actuator_share_with_the_duty():
    """At duty D the forward band drops by r D F_c and the reverse one by r D F_c x reverse_ratio."""
    form, plain, p = _pair("dither_friction", [20.0])
    ang = np.array([12.0])
    drive((form, plain), 6.0, 0.005)
    af = form.cfg.effects.actuator_friction
    (f1, r1), (f0, r0) = form.friction_limits(ang), plain.friction_limits(ang)
    assert np.allclose(f0 - f1, p["r"] * 0.5 * af.force_n)
    assert np.allclose(r0 - r1, p["r"] * 0.5 * af.force_n * af.reverse_ratio)


def test_ripple_offset_is_largest_at_half_duty_and_zero_at_rest():
    """Same state and noise: the reading is higher by g 4 D (1 - D); nothing at rest, g at half duty."""
    form, plain, p = _pair("ripple_offset", [20.0])
    assert np.array_equal(form.read().load_cell_n, plain.read().load_cell_n)  # at rest
    for volts in (6.0, -3.0):
        drive((form, plain), volts, 0.01)
        d = abs(volts) / 12.0
        diff = form.read().load_cell_n - plain.read().load_cell_n
        assert np.allclose(diff, p["g"] * 4 * d * (1 - d))


def test_mains_hum_is_the_law_in_session_time_and_zero_mean():
    """The load cell differs by A sin(2 pi f (t + TRIAL_GAP_S i) + phi) for trial i (same noise), which
    averages out over a second and differs between trials."""
    cls, cfg, p = form_case("mains_hum", 0)
    form, plain = cls(cfg, np.array([20.0, 20.0]), seed=1), Plant(cfg, np.array([20.0, 20.0]), seed=1)
    hum, want = [], []
    for _ in range(100):
        hum.append(form.read().load_cell_n - plain.read().load_cell_n)
        session = form.t + TRIAL_GAP_S * np.arange(2)
        want.append(p["amp"] * np.sin(2 * np.pi * p["freq"] * session + p["phase"]))
        for _ in range(10):
            form.step(0.0)
            plain.step(0.0)
    h = np.array(hum)
    assert np.allclose(h, want, atol=1e-9)
    assert abs(h.mean(axis=0)).max() < 0.1 * p["amp"] and h.std(axis=0).min() > 0.5 * p["amp"]
    assert not np.allclose(h[:, 0], h[:, 1])


def test_pot_dropouts_only_while_the_wiper_moves_and_deterministic():
    """Dropouts read low by far, occur only while the wiper moves, at about rate p, the same for the seed."""
    moves = [Move(a, 4.0, 12.0, -7.0) for a in (10.0, 14.0, 18.0, 22.0, 26.0)]
    _, truth, base = _trials("pot_dropouts", moves)
    again = _trials("pot_dropouts", moves)[1]
    drops = rows = 0
    for a, b, c in zip(truth, base, again, strict=True):
        assert a.equals(c)
        n = min(len(a), len(b))
        diff = b["pot"].to_numpy()[:n] - a["pot"].to_numpy()[:n]
        assert (diff >= 0).all()
        drops += int((diff > 300).sum())
        rows += n
    assert 0 < drops < 0.1 * rows


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="set C, run out of sample on the closest single change: 4/8 named first (goal >= 90 %), 5/8 "
    "after every single's polish (in-sample for it), 0/10 wrong names claimed at >= 0.9 "
    "(docs/discrepancy.md): frictions on the shaft are named by another friction law; kept as the check "
    "the search must pass",
)
def test_naming_goal_on_set_c():
    """The issue's goal on forms never used to tune the rule or the name given first: the closest effect
    named first in >= 90 % of the named cases, a wrong name claimed at >= 0.9 in <= 5 % (one seed each)."""
    rows = [run_form(name, 0) for name in FORMS]
    k = rates(rows)
    assert k["closest_first_rate"] >= 0.9 and k["wrong_sure_rate"] <= 0.05, [
        (r["form"], r["first"], r["wrong_sure"]) for r in rows
    ]
