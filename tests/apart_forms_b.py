"""A second held-out set of effect forms written apart from the discrepancy naming rule (set B).

Written by another separate author who had not read the naming/claim rule (seagen/discrepancy/candidates.py,
workflow.py, signature.py, report.py, nor docs/discrepancy.md's description of it): only the Plant interface
(seagen/plant/), the catalogue's effect laws (seagen/plant/config.py), the family module's conventions
(seagen/discrepancy/families.py) and the first set's harness (tests/apart_forms.py) were read. Set B was
written while the rule was being tuned on set A (tests/apart_forms.py), so set A became in-sample and this
set is the held-out one. Each form is a law a real SEA could show, physically different from the catalogue's
own laws, from the benchmark families and from set A's ten forms.

The expected names were fixed, with the reason, before any run of the workflow on these forms, and are not
to be changed after seeing results. An empty `expected` means no catalogue effect's law is close: the right
answer there is "unexplained / closest, not claimed" (every claim at >= 0.9 counts as wrong).

Conventions as in set A and families.py: a form that stands in for an effect the default plant enables
switches that effect off in both the truth and the base (`replaces`); every other effect of the default plant
stays as it is. Parameters are drawn per seed from the stated ranges (plausible for the paper's actuator,
visible above the sensor noise). Forms that drift over a session number the trials of the batch in the
order the protocol runs them (trial i starts TRIAL_GAP_S after trial i-1), as families.DriftingOffset does.

The harness (form_case, run_form, rates, table, main) is set A's, run on this set's FORMS:
    .venv/bin/python tests/apart_forms_b.py [--seeds N] [--forms a,b] [--quick] [--json rows.json]
"""

from __future__ import annotations

from collections import deque
from typing import Any

import apart_forms as _a
import numpy as np
from apart_forms import Form

from seagen.plant import Plant, PlantConfig, pick

TRIAL_GAP_S = 4.0  # session time between the starts of consecutive trials of a batch (s)


class CoilRubSpring(Plant):
    """The spring's coils rub on a guide rod fixed to the output shaft: a friction force in parallel with
    the spring, between nut and shaft (not between shaft and ground). The spring transmits k d + z, where
    z follows a Dahl loop in the compression d: dz/dd = (1 - sign(dd) z / h) h / x_y (z -> +h while
    compressing, -h while extending; x_y the compression over which the coils break loose). Within a step z
    is the loop's exact value at the trial compression, so the shaft solve sees it (a lagged z chatters)."""

    h, x_y = 0.8, 0.06  # N, mm

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, with the rubbing force z = 0 at rest, at compression 0."""
        super().__init__(cfg, contact_deg, seed)
        self._z = np.zeros_like(self.nut_mm)
        self._d0 = np.zeros_like(self.nut_mm)

    def _loop(self, d: np.ndarray, idx: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """z and dz/dd at compression d, from (d0, z0) at the end of the last step (one sign of dd: exact)."""
        z0, dd = pick(self._z, idx), d - pick(self._d0, idx)
        sgn = np.where(dd >= 0, 1.0, -1.0)
        e = np.exp(-np.abs(dd) / self.x_y)
        return sgn * self.h + (z0 - sgn * self.h) * e, (self.h - sgn * z0) / self.x_y * e

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The plant's spring plus the rubbing force."""
        return super().spring_force(d, idx) + self._loop(d, idx)[0]

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The slope of spring_force (>= the spring's: z rises with d)."""
        return super()._spring_slope(d, idx) + self._loop(d, idx)[1]

    def step(self, motor_v: Any) -> None:
        """Step, then fix z at this step's final compression."""
        super().step(motor_v)
        d = self.nut_mm - self.shaft_mm
        self._z, self._d0 = self._loop(d, None)[0], d


class DwellFriction(Plant):
    """Rate-and-state (Dieterich-Ruina aging) friction on the shaft: a contact age theta grows while the
    shaft rests (d theta = dt) and is worn away by sliding (theta -> theta exp(-|dy|/D_c)); the friction
    band gains a ln(1 + theta / t0). Break-away after a rest is stronger the longer the rest; in steady
    sliding theta = D_c / v, a weak velocity-weakening. The shaft has rested rest_s before each trial."""

    a, t0, dc = 0.45, 0.02, 0.02  # N, s, mm
    rest_s = 2.0  # s at rest before the trial starts

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, with the contact age of a shaft that has rested rest_s."""
        super().__init__(cfg, contact_deg, seed)
        self._theta = np.full_like(self.nut_mm, self.rest_s)

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's other friction plus the aging term, the same both ways."""
        fwd, rev = super().friction_limits(angle_deg)
        boost = self.a * np.log1p(self._theta / self.t0)
        return fwd + boost, rev + boost

    def step(self, motor_v: Any) -> None:
        """Step, then age the contact by dt and wear it by this step's slide."""
        y0 = self.shaft_mm
        super().step(motor_v)
        self._theta = self._theta * np.exp(-np.abs(self.shaft_mm - y0) / self.dc) + self.cfg.dt_s


class WarmingGrease(Plant):
    """Grease on the output shaft's guide thins as the rig warms up over the session: a speed-proportional
    drag b(s) v whose coefficient falls from b0 (cold, first trial) toward b_inf with time constant tau in
    session time s = t + TRIAL_GAP_S x (trial number). Stands in for any viscous_friction of the config."""

    b0, b_inf, tau = 0.18, 0.03, 25.0  # N s/mm, N s/mm, s

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, and each trial's start in session time."""
        super().__init__(cfg, contact_deg, seed)
        self._cfg0 = cfg
        self._start = TRIAL_GAP_S * np.arange(self.nut_mm.size)

    def drag(self) -> np.ndarray:
        """The drag coefficient of each trial now (N s/mm)."""
        return self.b_inf + (self.b0 - self.b_inf) * np.exp(-(self.t + self._start) / self.tau)

    def step(self, motor_v: Any) -> None:
        """Step with the plant's viscous term set to this instant's per-trial coefficient."""
        self.cfg = self._cfg0.with_effect("viscous_friction", True, b_n_s_per_mm=self.drag())
        super().step(motor_v)


class BucklingSpring(Plant):
    """A long compression spring that bows sideways in its guide past a compression d_b (Euler buckling):
    its rate falls smoothly from k to r k there, F = r k d + (1 - r) k [d - s (softplus((d - d_b)/s) -
    softplus(-d_b/s))] for d >= 0 (softening; the catalogue's spring nonlinearity only hardens)."""

    r, d_b, soft = 0.82, 2.0, 0.3  # post-buckling rate / k, mm, mm

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant; k_spring becomes the post-buckling rate r k (the least slope, which the shaft solver's
        bracket assumes), the rest of the rate is added back below the knee."""
        super().__init__(cfg, contact_deg, seed)
        self._k0 = self.k_spring
        self.k_spring = self.r * self._k0

    def _knee(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The (1 - r) k part of the force and its slope at compression d >= 0."""
        dk = (1.0 - self.r) * self._k0
        u = (d - self.d_b) / self.soft
        f = dk * (d - self.soft * (np.logaddexp(0.0, u) - np.logaddexp(0.0, -self.d_b / self.soft)))
        return f, dk * (1.0 - 1.0 / (1.0 + np.exp(-u)))

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The plant's spring at rate r k plus the part that buckles away (nothing added below d = 0)."""
        return super().spring_force(d, idx) + np.where(d >= 0, self._knee(np.maximum(d, 0.0))[0], 0.0)

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The slope of spring_force."""
        return super()._spring_slope(d, idx) + np.where(d >= 0, self._knee(np.maximum(d, 0.0))[1], 0.0)


class AdcCrosstalk(Plant):
    """The pot and the load-cell amplifier share a multiplexed ADC whose sample-and-hold does not settle
    between channels: the pot reading keeps c counts per newton of the load-cell channel's reading (tip
    force, with its noise). The pot's reference itself is clean (own regulator: no current-dependent drop)."""

    c = 3.5  # pot counts per N of load-cell reading

    def read(self):
        """The reading with the load-cell channel's share added to the pot."""
        s = super().read()
        s.pot = np.clip(np.rint(s.pot + self.c * s.load_cell_n), 0, self.geo.adc_max).astype(np.int64)
        return s


class AdcEarly(Plant):
    """The control loop starts the ADC conversions (pot and load cell) at the top of the loop and reads the
    encoder counter delay_s later (after the slow peripherals), logging both on one row: relative to the
    encoder, the pot and the load cell are delay_s old (whole plant steps)."""

    delay_s = 0.006

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, and a buffer of its states over the last delay (the rest state before t = 0)."""
        super().__init__(cfg, contact_deg, seed)
        self._past: deque = deque(maxlen=int(round(self.delay_s / cfg.dt_s)) + 1)
        self._past.append(self._state())

    def _state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What the pot and load-cell readings are made from: shaft, pot drop, force history."""
        return self.shaft_mm.copy(), self.pot_drop.copy(), self._history.copy()

    def step(self, motor_v: Any) -> None:
        """Step, then remember the state."""
        super().step(motor_v)
        self._past.append(self._state())

    def read(self):
        """Pot and load cell from the oldest remembered state; the encoder from the motor now."""
        now = self._state()
        self.shaft_mm, self.pot_drop, self._history = (x.copy() for x in self._past[0])
        try:
            s = super().read()
        finally:
            self.shaft_mm, self.pot_drop, self._history = now
        s.enc = np.floor(self.motor_mm / self.geo.mm_per_count + 1e-9).astype(np.int64)
        return s


class CurrentLimit(Plant):
    """The H-bridge driver limits the motor current to i_max (as a fraction of the stall current at the
    supply): when the command would draw more (starting from rest, reversing), the driver lowers the voltage
    to V = V_s (+-i_max + v / v_max). Steady pushes (current = load / stall) stay under the limit."""

    i_max = 0.25

    def step(self, motor_v: Any) -> None:
        """Step with the current-limited voltage (the limit computed from the speed before the step)."""
        m = self.motor
        volts = np.clip(np.asarray(motor_v, dtype=float), -m.supply_v, m.supply_v)
        back = self.v_motor / self.v_max
        amps = np.clip(volts / m.supply_v - back, -self.i_max, self.i_max)
        super().step(m.supply_v * (amps + back))


class PotBow(Plant):
    """Integral nonlinearity of the pot's resistive track after the usual two-point calibration at the ends
    of the linkage range: the reading bows by 4 b x (1 - x), x = (angle - angle_min) / (angle_max -
    angle_min) of the wiper's angle (zero at both calibration ends, b counts in the middle)."""

    b = 35.0  # counts

    def read(self):
        """The reading plus the bow at the angle the pot sees."""
        s = super().read()
        g = self.geo
        seen = g.angle_from_shaft(np.minimum(self.shaft_mm, self.y_contact))
        x = (seen - g.angle_min_deg) / (g.angle_max_deg - g.angle_min_deg)
        s.pot = np.clip(np.rint(s.pot + 4 * self.b * x * (1 - x)), 0, g.adc_max).astype(np.int64)
        return s


class GearRunout(Plant):
    """Transmission error of the gear train (eccentric last-stage pinion): the nut is ahead of the motor
    (encoder) by A (sin(2 pi m / p + phi) - sin(phi)), periodic in the motor's travel m with the pinion's
    period p of nut travel; zero at the homed start. Stands in for the nut law (the catalogue's backlash is
    off in the default plant)."""

    amp, period, phase = 0.09, 3.0, 1.0  # mm, mm, rad

    def _move_nut(self) -> None:
        """Nut = motor + the periodic error."""
        w = 2 * np.pi / self.period
        self.nut_mm = self.motor_mm + self.amp * (np.sin(w * self.motor_mm + self.phase) - np.sin(self.phase))


class PivotFriction(Plant):
    """Friction torque T_f in the linkage's pivot (a preloaded bushing), reflected to the shaft by virtual
    work: F = T_f / (dy/dtheta) = T_f / (CB sin(angle)), the same both ways; largest near home, falling as
    the linkage opens. Stands in for the catalogue's linkage friction."""

    torque = 6.5  # N mm

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's other friction plus the pivot's, at this linkage angle."""
        fwd, rev = super().friction_limits(angle_deg)
        home = np.maximum(angle_deg, self.geo.home_deg)  # the linkage rests on its stop at home
        band = self.torque / (self.geo.cb_mm * np.sin(np.radians(home)))
        return fwd + band, rev + band


# Expected names and reasons: fixed before any run of the workflow on these forms; do not edit after.
FORMS: dict[str, Form] = {
    "coil_rub_spring": Form(
        CoilRubSpring,
        None,
        {"h": (0.5, 1.0), "x_y": (0.03, 0.10)},
        frozenset({"actuator_friction"}),
        "a direction-dependent Coulomb band in the force-compression balance: friction in parallel with the "
        "spring enters every sensor relation as a shaft friction lower by h both ways, so a lower "
        "actuator_friction (and its reverse ratio) is the closest catalogue change",
    ),
    "dwell_friction": Form(
        DwellFriction,
        None,
        {"a": (0.3, 0.6), "t0": (0.01, 0.04), "dc": (0.01, 0.04)},
        frozenset({"stribeck_friction"}),
        "extra friction at break-away from rest that fades once the shaft slides (and grows at low speed): "
        "the catalogue's Stribeck term, here driven by the time at rest instead of the speed alone",
    ),
    "warming_grease": Form(
        WarmingGrease,
        None,
        {"b0": (0.12, 0.25), "b_inf": (0.02, 0.05), "tau": (15.0, 40.0)},
        frozenset({"viscous_friction"}),
        "a speed-proportional drag on the shaft, zero at rest; only its coefficient falls over the session",
    ),
    "buckling_spring": Form(
        BucklingSpring,
        None,
        {"r": (0.75, 0.9), "d_b": (1.5, 2.5)},
        frozenset({"series_compliance"}),
        "extra nut travel per newton that grows with the force and that the pot does not see (the shaft "
        "stops at contact either way): the structure deflection's signature; the catalogue's spring "
        "nonlinearity only hardens",
    ),
    "adc_crosstalk": Form(
        AdcCrosstalk,
        "pot_voltage_drop",
        {"c": (2.5, 4.5)},
        frozenset({"pot_voltage_drop"}),
        "an additive pot error that grows with the load: the catalogue's only law offsetting the pot while "
        "the actuator is loaded (holding, |current| = load / stall, so its drop is proportional to force)",
    ),
    "adc_early": Form(
        AdcEarly,
        None,
        {"delay_s": (0.004, 0.009)},
        frozenset({"transport_delay"}),
        "the load cell reads the force late relative to the drive (the encoder), by a few milliseconds: the "
        "catalogue's transport delay (the pot's equal lag is not in its law)",
    ),
    "current_limit": Form(
        CurrentLimit,
        None,
        {"i_max": (0.2, 0.3)},
        frozenset(),
        "none: no catalogue effect acts on the drive's voltage-to-speed law (the motor itself accelerates "
        "slower at starts and reversals; the sensors agree with each other throughout)",
    ),
    "pot_bow": Form(
        PotBow,
        None,
        {"b": (25.0, 45.0)},
        frozenset(),
        "none: a pot error that depends on the angle only (zero at the range's ends); the catalogue's pot "
        "effects depend on the current (pot_voltage_drop) or are zero-mean noise",
    ),
    "gear_runout": Form(
        GearRunout,
        None,
        {"amp": (0.07, 0.12), "period": (2.5, 4.0), "phase": (0.0, 2 * np.pi)},
        frozenset(),
        "none: a motor-to-nut error periodic in position, the same both ways; backlash (the only "
        "motor-to-nut effect) depends on the direction, not the position",
    ),
    "pivot_friction": Form(
        PivotFriction,
        "linkage_friction",
        {"torque": (4.0, 9.0)},
        frozenset({"linkage_friction"}),
        "Coulomb friction on the shaft that depends on the linkage angle (1 / sin(angle) instead of the "
        "catalogue's quadratic)",
    ),
}


HARNESS = _a.Harness(FORMS)  # set A's harness on this set's forms
form_case, run_form, main = HARNESS.form_case, HARNESS.run_form, HARNESS.main
rates, table = _a.rates, _a.table


if __name__ == "__main__":
    raise SystemExit(main())
