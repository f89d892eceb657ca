"""Set D of the forms written apart from the naming rule (tests/apart_forms_d.py): each law does what its
docstring says, without running the discrepancy workflow."""

from __future__ import annotations

from functools import partial

import apart_forms
import apart_forms_b
import apart_forms_c
import numpy as np
import pytest
from apart_forms_d import FORMS, form_case
from test_apart_forms import drive, form_pair

from seagen.plant import Plant, kernel

FRICTION = {"actuator_friction", "linkage_friction", "viscous_friction", "stribeck_friction"}


_pair = partial(form_pair, form_case)


def test_set_d_has_ten_new_forms():
    """Ten forms, eight with an expected name (seven different effects at least, at most two on friction),
    none named like a form of sets A-C nor sharing a class with them."""
    assert len(FORMS) == 10
    named = [f.expected for f in FORMS.values() if f.expected]
    assert len(named) == 8 and len(set().union(*named)) >= 7
    assert sum(bool(e & FRICTION) for e in named) <= 2
    others = [m.FORMS for m in (apart_forms, apart_forms_b, apart_forms_c)]
    assert not set(FORMS) & set().union(*(set(o) for o in others))
    assert not {f.cls for f in FORMS.values()} & {f.cls for o in others for f in o.values()}


@pytest.mark.parametrize("name", list(FORMS))
def test_form_is_not_a_plain_plant_for_the_compiled_kernel(name):
    """The compiled kernel does not take a form for a plain plant (its law would be skipped); the law's
    visibility is checked with sets B and C in test_apart_forms.py."""
    cls, cfg, _ = form_case(name, 0)
    assert not kernel.available(cls(cfg, np.array([10.0])))


def test_caged_spring_is_stiff_below_the_preload_then_offset():
    """F = m k d up to F0, then F0 + k (d - F0 / (m k)): continuous, the spring's rate above the knee."""
    form, plain, p = _pair("caged_spring", [20.0])
    k = plain.k_spring
    knee = p["f0"] / (p["m"] * k)
    d = np.array([-0.2, 0.0, 0.5 * knee, knee, 1.0, 4.0])
    want = np.where(
        d < 0, plain.spring_force(d), np.where(d < knee, p["m"] * k * d, p["f0"] + k * (d - knee))
    )
    assert np.allclose(form.spring_force(d), want)
    assert np.allclose(form._spring_slope(d), [plain.k_stop, p["m"] * k, p["m"] * k, k, k, k])
    assert np.allclose(
        form.spring_force(np.array([3.0])) - plain.spring_force(np.array([3.0])), p["f0"] * (1 - 1 / p["m"])
    )


def test_tapered_spring_is_logarithmic_and_its_slope_is_the_derivative():
    """F = -k d_s ln(1 - d / d_s) for 0 <= d <= 0.9 d_s, slope k / (1 - d / d_s); below 0: the plant's."""
    form, plain, p = _pair("tapered_spring", [20.0])
    k, ds = plain.k_spring, p["d_s"]
    d = np.array([0.0, 1.0, 3.0, 5.0, 0.9 * ds])
    assert np.allclose(form.spring_force(d), -k * ds * np.log(1 - d / ds))
    assert np.allclose(form._spring_slope(d), k / (1 - d / ds))
    h = 1e-6
    assert np.allclose(
        (form.spring_force(d[1:] + h) - form.spring_force(d[1:] - h)) / (2 * h), form._spring_slope(d[1:])
    )
    neg = np.array([-0.3])
    assert np.array_equal(form.spring_force(neg), plain.spring_force(neg))


def test_bending_arm_adds_r2_over_k_arm_in_series():
    """The shaft's advance beyond contact for force F is F (1 / k + R_l^2 / k_arm) + beta F^2 (per angle)."""
    form, _, p = _pair("bending_arm", [8.0, 22.0])
    sc = form.cfg.effects.series_compliance
    force = np.array([3.0, 15.0])
    y = (
        form.y_contact
        + force * (1 / sc.k_n_per_mm + form.ratio**2 / p["k_arm"])
        + sc.beta_mm_per_n2 * force**2
    )
    f, s = form.structure_force(y)
    assert np.allclose(f, force)
    h = 1e-7
    assert np.allclose((form.structure_force(y + h)[0] - form.structure_force(y - h)[0]) / (2 * h), s)
    assert np.array_equal(form.read().pot, Plant(form.cfg, np.array([8.0, 22.0]), seed=1).read().pot)


def test_reservoir_ref_pot_rises_slowly_and_falls_fast():
    """Same state and noise: the pot reads rint(plain + e), e follows c |i| with tau_up rising and tau_down
    falling (checked step by step against the recursion)."""
    form, plain, p = _pair("reservoir_ref_pot", [20.0])
    e = np.zeros(1)
    for volts, steps in ((5.0, 60), (0.0, 40), (-7.0, 30)):
        for _ in range(steps):
            form.step(volts)
            plain.step(volts)
            target = p["c"] * np.abs(plain.current)
            tau = p["tau_up"] if target[0] > e[0] else p["tau_down"]
            e = e + (target - e) * min(0.001 / tau, 1.0)
        assert np.allclose(form._e, e)
        assert np.array_equal(form.read().pot, np.rint(plain.read().pot + e).astype(np.int64))


def test_boxcar_cell_reads_the_mean_of_the_last_window():
    """Same state and noise: the reading is the plain one less the tip force plus the mean tip force of the
    last round(T / dt) steps."""
    form, plain, p = _pair("boxcar_cell", [10.0])
    n = int(round(p["window_s"] / 0.001))
    tips = []
    for k in range(400):
        volts = 5.0 if k < 300 else -8.0
        form.step(volts)
        plain.step(volts)
        tips.append(plain.shaft_force[0] * plain.ratio[0])
        if k % 10 == 9:
            a, b = form.read(), plain.read()
            want = b.load_cell_n[0] - tips[-1] + np.mean((([0.0] * n) + tips)[-n:])
            assert np.isclose(a.load_cell_n[0], want)
    assert max(tips) > 3.0


def test_remounted_cell_reads_the_plate_only_on_the_vertical_mount():
    """Same state and noise: +w above the split angle, nothing below."""
    form, plain, p = _pair("remounted_cell", [10.0, 20.0])
    drive((form, plain), 4.0, 0.3)
    assert np.allclose(form.read().load_cell_n - plain.read().load_cell_n, [0.0, p["w"]])


def test_worn_screw_clearance_narrows_along_the_screw():
    """Pushed out, the nut trails the motor by b(m); after a reversal it leads it by b(m)."""
    form, _, p = _pair("worn_screw", [26.0])

    def b(m: float) -> float:
        return p["b_min"] + (p["b_max"] - p["b_min"]) * np.exp(-m / p["length"])

    drive((form,), 4.0, 0.3)
    m = form.motor_mm[0]
    assert m > 1.0 and np.isclose(m - form.nut_mm[0], b(m))
    drive((form,), -6.0, 0.05)
    m = form.motor_mm[0]
    assert np.isclose(form.nut_mm[0] - m, b(m))


def test_pivot_damper_is_c_over_lever_squared_and_off_in_contact():
    """The viscous coefficient is c_theta / (CB sin angle)^2 in free motion, nothing on the load cell."""
    form, _, p = _pair("pivot_damper", [10.0, 26.0])
    g = form.geo
    assert np.allclose(
        form.viscous_n_s_per_mm(), p["c_theta"] / (g.cb_mm * np.sin(np.radians(g.home_deg))) ** 2
    )
    drive((form,), 4.0, 0.05)
    ang = g.angle_from_shaft(form.shaft_mm)
    assert (form.shaft_mm < form.y_contact).all()
    assert np.allclose(form.viscous_n_s_per_mm(), p["c_theta"] / (g.cb_mm * np.sin(np.radians(ang))) ** 2)
    drive((form,), 4.0, 1.0)
    assert form.shaft_mm[0] > form.y_contact[0] and form.viscous_n_s_per_mm()[0] == 0.0


def test_missed_counts_caps_the_count_rate_and_keeps_the_loss():
    """Slow, the encoder counts every edge; fast, it advances f_max per second and the loss stays."""
    form, plain, p = _pair("missed_counts", [26.0])
    drive((form, plain), 1.0, 0.2)  # ~2.4 mm/s: ~540 counts/s
    assert abs(int(form.read().enc[0]) - int(plain.read().enc[0])) <= 1
    m0, c0 = plain.read().enc[0], form._counted[0]
    drive((form, plain), -12.0, 0.1)  # ~28 mm/s: ~6000 counts/s once up to speed
    fast = plain.read().enc[0] - m0
    assert fast < -1.5 * p["f_max"] * 0.1
    assert form._counted[0] - c0 >= -p["f_max"] * 0.1 - 1e-6
    drive((form, plain), 1.0, 0.1)
    assert form.read().enc[0] - plain.read().enc[0] > 0.3 * p["f_max"] * 0.1


def test_supply_sag_is_the_plain_plant_at_the_sagged_voltage():
    """Step by step the form is the plain plant driven at V_eff = (V + rho V_s v / v_max) / (1 + rho) (v the
    motor's speed before the step), so at stall (v = 0) the motor sees V / (1 + rho)."""
    form, plain, p = _pair("supply_sag", [10.0])
    vs = plain.motor.supply_v
    for volts, steps in ((4.0, 300), (2.0, 700), (-7.0, 200)):
        for _ in range(steps):
            v_eff = (volts + p["rho"] * vs * plain.v_motor / plain.v_max) / (1 + p["rho"])
            form.step(volts)
            plain.step(v_eff)
            assert np.array_equal(form.motor_mm, plain.motor_mm) and np.array_equal(
                form.shaft_mm, plain.shaft_mm
            )
        if volts == 2.0:  # slowing in contact: the motor sees well under the command
            assert form.shaft_force[0] > 5.0 and v_eff[0] < 2.0 / (1 + 0.5 * p["rho"])
