"""Set B of the forms written apart from the naming rule (tests/apart_forms_b.py): each law does what its
docstring says, without running the discrepancy workflow."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
from apart_forms_b import FORMS, TRIAL_GAP_S, form_case, rates, run_form
from test_apart_forms import drive, form_pair, form_trials  # set A's moves and noise units

from seagen.data.protocol import Move
from seagen.plant import Plant, PlantConfig

_trials = partial(form_trials, form_case)  # this set's forms
_pair = partial(form_pair, form_case)


def _drive(plant: Plant, volts: float, seconds: float) -> dict[str, np.ndarray]:
    """Step `plant` at constant volts; per step: compression, shaft, motor, nut, current (step x batch)."""
    return drive((plant,), volts, seconds)[0]


def test_set_b_has_ten_forms():
    """Set B has ten forms (the shared checks of both sets are in test_apart_forms.py)."""
    assert len(FORMS) == 10


def test_coil_rub_spring_lowers_the_compression_needed_to_push_by_z():
    """Pushing in free motion the spring carries k d + z, z near +h: the compression is lower by z / k than
    the plain plant's; retracting, z goes to -h (the band reverses)."""
    form, plain, p = _pair("coil_rub_spring", [24.0])
    a, b = _drive(form, 4.0, 0.25), _drive(plain, 4.0, 0.25)
    assert 0.5 * p["h"] < form._z[0] <= p["h"]
    gap = (b["d"][-1, 0] - a["d"][-1, 0]) * plain.k_spring
    assert abs(gap - form._z[0]) < 0.15 * p["h"], (gap, form._z[0])
    _drive(form, -4.0, 0.1)
    assert form._z[0] < -0.9 * p["h"]
    d = np.linspace(-0.2, 1.0, 50)
    assert (np.diff(form.spring_force(d)) > 0).all()  # monotone: the shaft solve's bracket holds


def test_dwell_friction_delays_break_away_then_fades_while_sliding():
    """After the rest the shaft breaks away later (more compression); sliding, most extra band goes."""
    form, plain, p = _pair("dwell_friction", [24.0])
    a, b = _drive(form, 3.0, 0.4), _drive(plain, 3.0, 0.4)
    first = [int(np.argmax(r["y"][:, 0] > 1e-3)) for r in (a, b)]
    assert first[0] > first[1]
    rest_band = p["a"] * np.log1p(form.rest_s / p["t0"])
    peak_extra = (a["d"][:, 0].max() - b["d"][:, 0].max()) * plain.k_spring
    assert 0.6 * rest_band < peak_extra < 1.2 * rest_band, (peak_extra, rest_band)
    sliding_extra = (a["d"][-1, 0] - b["d"][-1, 0]) * plain.k_spring
    assert 0 < sliding_extra < 0.5 * rest_band


def test_warming_grease_drag_falls_over_the_session():
    """Twelve identical trials in session order: the extra compression of the free push (drag b v) falls from
    the first trial to the last, and the coefficient follows b_inf + (b0 - b_inf) exp(-s / tau)."""
    form, plain, p = _pair("warming_grease", [24.0] * 12)
    a, b = _drive(form, 4.0, 0.2), _drive(plain, 4.0, 0.2)
    extra = a["d"][-1] - b["d"][-1]
    assert (extra > 0).all() and (np.diff(extra) < 0).all()
    s = form.t + TRIAL_GAP_S * np.arange(12)
    assert np.allclose(form.drag(), p["b_inf"] + (p["b0"] - p["b_inf"]) * np.exp(-s / p["tau"]))
    v = (b["y"][-1, 0] - b["y"][-2, 0]) / plain.cfg.dt_s
    assert 0.7 < extra[0] * plain.k_spring / (form.drag()[0] * v) < 1.3


def test_buckling_spring_softens_past_the_knee_only():
    """Below the knee the spring is the plain one (within 2 %), beyond it weaker; its slope stays >= r k; and
    pushing to the same force takes more encoder travel."""
    form, plain, p = _pair("buckling_spring", [15.0])
    k = plain.k_spring
    low = np.linspace(0.0, p["d_b"] - 1.0, 20)
    assert np.allclose(form.spring_force(low), plain.spring_force(low), rtol=0.02, atol=1e-9)
    high = np.linspace(p["d_b"] + 0.5, 6.0, 20)
    assert (form.spring_force(high) < plain.spring_force(high) - 0.05 * k * (high - p["d_b"])).all()
    d = np.linspace(0.0, 6.0, 200)
    assert (form._spring_slope(d) >= p["r"] * k - 1e-9).all()
    assert np.allclose(np.gradient(form.spring_force(d), d)[1:-1], form._spring_slope(d)[1:-1], rtol=0.01)
    _, truth, base = _trials("buckling_spring")
    for a, b in zip(truth, base, strict=True):
        assert a["enc"].max() > b["enc"].max() + 20


def test_adc_crosstalk_adds_c_times_the_load_cell_reading_to_the_pot():
    """Same noise: the pot differs by exactly rint(c x load-cell reading); encoder and load cell unchanged."""
    p, truth, base = _trials("adc_crosstalk")
    for a, b in zip(truth, base, strict=True):
        assert np.array_equal(a["enc"], b["enc"]) and np.array_equal(a["load_cell_n"], b["load_cell_n"])
        diff = a["pot"].to_numpy() - b["pot"].to_numpy()
        assert np.array_equal(diff, np.rint(p["c"] * b["load_cell_n"].to_numpy()).astype(np.int64))


def test_adc_early_makes_pot_and_load_cell_lag_the_encoder():
    """The encoder is the plain plant's; the pot and the load cell read what the plain plant read delay_s
    earlier: lower while they rise (push)."""
    p, truth, base = _trials("adc_early")
    for a, b in zip(truth, base, strict=True):
        assert np.array_equal(a["enc"], b["enc"])
        rising = np.flatnonzero(np.diff(b["load_cell_n"].to_numpy()) > 0.2) + 1
        assert (a["load_cell_n"].to_numpy() - b["load_cell_n"].to_numpy())[rising].mean() < -0.05
    form, plain, _ = _pair("adc_early", [24.0])
    lag = int(round(p["delay_s"] / plain.cfg.dt_s))
    angles = []
    for _ in range(150):  # free push (breaks away after ~60 steps), then the shaft advances
        form.step(4.0)
        plain.step(4.0)
        angles.append(plain.geo.angle_from_shaft(plain.shaft_mm)[0])
    s = form.read()
    assert np.array_equal(form.shaft_mm, plain.shaft_mm)  # the dynamics are the plain plant's
    assert s.angle_deg[0] == angles[-1 - lag] < angles[-1]  # the reading is made from the state lag steps ago


def test_current_limit_caps_the_current_and_slows_starts_and_reversals():
    """From rest at 5 V, and reversing to -8 V, the plain motor draws more than i_max; the limited one stays
    at i_max (one step's lag), its encoder lags (most after the reversal); steady speeds match."""
    form, plain, p = _pair("current_limit", [24.0])
    a, b = _drive(form, 5.0, 0.15), _drive(plain, 5.0, 0.15)
    assert np.abs(b["current"]).max() > p["i_max"] + 0.05
    assert np.abs(a["current"]).max() < p["i_max"] + 0.02
    assert a["motor"][-1, 0] < b["motor"][-1, 0] - 0.01
    va, vb = (np.diff(r["motor"][-2:, 0])[0] for r in (a, b))
    assert abs(va - vb) < 0.02 * vb
    lag0 = b["motor"][-1, 0] - a["motor"][-1, 0]
    a, b = _drive(form, -8.0, 0.15), _drive(plain, -8.0, 0.15)
    assert np.abs(b["current"]).max() > p["i_max"] + 0.2
    assert np.abs(a["current"]).max() < p["i_max"] + 0.02
    assert a["motor"][-1, 0] - b["motor"][-1, 0] > lag0 + 0.2  # retracting, the limited motor is behind


def test_pot_bow_is_zero_at_the_range_ends_and_b_in_the_middle():
    """Loaded at its contact angle, the pot reads rint(4 b x (1 - x)) high (same noise); more mid-range."""
    g = PlantConfig().actuator.linkage
    mid = 0.5 * (g.angle_min_deg + g.angle_max_deg)
    p, truth, base = _trials("pot_bow", [Move(6.0, 5.0, 15.0, -8.0), Move(mid, 5.0, 15.0, -8.0)])
    offsets = []
    for a, b in zip(truth, base, strict=True):
        loaded = b["force_n"].to_numpy() > 3.0
        offsets.append(a["pot"].to_numpy()[loaded] - b["pot"].to_numpy()[loaded])
    x = (6.0 - g.angle_min_deg) / (g.angle_max_deg - g.angle_min_deg)
    assert np.all(offsets[0] == round(4 * p["b"] * x * (1 - x)))
    assert np.all(offsets[1] == round(p["b"]))


def test_gear_runout_is_periodic_in_the_motor_travel():
    """Nut - motor = A (sin(2 pi m / p + phi) - sin phi): zero at home, bounded by 2 A, the same both ways."""
    form, _, p = _pair("gear_runout", [24.0])
    a = _drive(form, 4.0, 0.4)
    r = _drive(form, -4.0, 0.2)
    for run in (a, r):
        m = run["motor"][:, 0]
        law = p["amp"] * (np.sin(2 * np.pi * m / p["period"] + p["phase"]) - np.sin(p["phase"]))
        assert np.allclose(run["nut"][:, 0] - m, law, atol=1e-12)
    assert np.ptp(a["motor"][:, 0]) > p["period"]  # at least one period seen
    assert np.abs(a["nut"] - a["motor"]).max() <= 2 * p["amp"] + 1e-12


def test_pivot_friction_is_torque_over_lever_and_falls_with_angle():
    """The extra band is T_f / (CB sin(angle)) both ways, held at its home value below home."""
    form, _, p = _pair("pivot_friction", [15.0])
    bare = Plant(form.cfg, np.array([15.0]))
    angles = np.array([2.0, 5.0, 6.0, 16.0, 28.0])
    (f1, r1), (f0, r0) = form.friction_limits(angles), bare.friction_limits(angles)
    cb = form.geo.cb_mm
    want = p["torque"] / (cb * np.sin(np.radians(np.maximum(angles, form.geo.home_deg))))
    assert np.allclose(f1 - f0, want) and np.allclose(r1 - r0, want)
    assert (np.diff(want[1:]) < 0).all() and want[1] / want[-1] > 4


@pytest.mark.slow
def test_set_b_runs_through_the_workflow():
    """Every form runs through the workflow (fast protocol) and gives a row; no naming figure is asserted."""
    rows = [run_form(name, 0, fast=True) for name in FORMS]
    assert [r["form"] for r in rows] == list(FORMS)
    assert set(rates(rows)) >= {"closest_first_rate", "wrong_sure_rate"}
