"""A third held-out set of effect forms written apart from the discrepancy naming rule (set C).

Written by a third separate author (the helper `formsc`) who had not read the naming/claim rule and was told
not to: only the Plant interface and the catalogue's effect laws (seagen/plant/), the trial protocol
(seagen/data/protocol.py), the family module's conventions and forms (seagen/discrepancy/families.py), sets A
and B with their tests (tests/apart_forms.py, tests/apart_forms_b.py, tests/test_apart_forms*.py), the
design notes' actuator and catalogue sections (/work/shared/DESIGN.md) and the actuator description were
read; no other file of seagen/discrepancy/, no docs/discrepancy.md, no git log about the discrepancy
workflow and no earlier result. Each form is a law a real SEA could show, physically different from the
catalogue's own laws, from the benchmark families and from sets A and B's twenty forms.

The expected names were fixed, each with its physical reason, before any run of the workflow on these forms
(by anyone), and are not to be changed after seeing results. The expected name is the catalogue effect whose
law a physicist would change first to approximate the form's law. An empty `expected` means no catalogue
effect's law is close: the right answer there is "unexplained / closest, not claimed" (every claim at >= 0.9
counts as wrong).

Conventions as in sets A and B and families.py: a form that stands in for an effect the default plant enables
switches that effect off in both the truth and the base (`replaces`: the closest change is then an addition);
a form that acts on top of an enabled effect leaves it on (`replaces` None: the closest change is then a
recalibration of that effect); every other effect of the default plant stays as it is. Parameters are drawn
per seed from the stated ranges (plausible for the paper's actuator, visible above the sensor noise). Forms
with their own randomness draw it from a generator seeded by the plant's seed (deterministic, and the plant's
own noise stream is left as it is). Forms that depend on session time number the trials of the batch in the
order the protocol runs them (trial i starts TRIAL_GAP_S after trial i-1), as families.DriftingOffset does.

The harness (form_case, run_form, rates, table, main) is set A's, run on this set's FORMS:
    .venv/bin/python tests/apart_forms_c.py [--seeds N] [--forms a,b] [--quick] [--json rows.json]
"""

from __future__ import annotations

from typing import Any

import apart_forms as _a
import numpy as np
from apart_forms import Form

from seagen.plant import Plant, PlantConfig, pick

TRIAL_GAP_S = 4.0  # session time between the starts of consecutive trials of a batch (s)


def _duty(plant: Plant, motor_v: Any) -> np.ndarray:
    """The H-bridge's PWM duty |V| / V_supply of a command, over the batch (clipped to 1)."""
    m = plant.motor
    volts = np.abs(np.broadcast_to(np.asarray(motor_v, dtype=float), plant.nut_mm.shape))
    return np.minimum(volts, m.supply_v) / m.supply_v


class _DutyPlant(Plant):
    """A plant that keeps its current command's PWM duty D (self._d) for its laws (Dither, Ripple)."""

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, the motor at rest (D = 0)."""
        super().__init__(cfg, contact_deg, seed)
        self._d = np.zeros_like(self.nut_mm)

    def step(self, motor_v: Any) -> None:
        """Step with this command's duty."""
        self._d = _duty(self, motor_v)
        super().step(motor_v)


class ReturnSpring(Plant):
    """A light extension spring that keeps the linkage homed pulls the output shaft back with R = f_r + k_r y
    (initial tension f_r, rate k_r, shaft advance y >= 0); the linkage's home stop holds it at y = 0 (stiff as
    the spring's own stop). A conservative force on the shaft: the same sign pushing and retracting."""

    f_r, k_r = 1.5, 0.2  # N, N/mm

    def _net_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The plant's net push on the shaft minus the return spring's pull (and its slope)."""
        f, s = super()._net_force(y, idx)
        k = np.where(y >= 0, self.k_r, self.k_stop)  # below home: the home stop pushes back
        return f - (self.f_r + k * y), s - k

    def _move_shaft(self, dt: float) -> None:
        """Plant's shaft motion, which solves with _net_force above (declared here so that this plant is not
        taken for one with Plant's own motion laws)."""
        super()._move_shaft(dt)


class FilmLagFriction(Plant):
    """Frictional lag of a lubricated guide: the extra low-speed friction dF / (1 + (s / v_s)^2) depends on a
    film speed s that follows the shaft's |v| with time constant tau (the oil film takes time to build up and
    to squeeze out), the same both ways. After a stop the full dF is back within a few tau."""

    df, v_s, tau = 1.5, 2.0, 0.05  # N, mm/s, s

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, its film at rest (s = 0)."""
        super().__init__(cfg, contact_deg, seed)
        self._s = np.zeros_like(self.nut_mm)

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's other friction plus the film-lag term."""
        fwd, rev = super().friction_limits(angle_deg)
        boost = self.df / (1.0 + (self._s / self.v_s) ** 2)
        return fwd + boost, rev + boost

    def step(self, motor_v: Any) -> None:
        """Step, then move the film speed toward this step's shaft speed."""
        super().step(motor_v)
        self._s = self._s + (np.abs(self.v_shaft) - self._s) * min(self.cfg.dt_s / self.tau, 1.0)


class CreepingHousing(Plant):
    """The 3D-printed housing creeps (viscoelastic polymer): in series with the catalogue's structure
    deflection a Kelvin-Voigt element (k2 parallel to a damper, time constant tau = c / k2) whose deflection
    x2 follows F / k2 with lag tau: the shaft goes x2 further beyond contact for the same force, the more the
    longer the load is held. x2 is held within a step and updated after it (tau >> dt)."""

    k2, tau = 45.0, 0.3  # N/mm, s

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, with the housing relaxed (x2 = 0)."""
        super().__init__(cfg, contact_deg, seed)
        self._x2 = np.zeros_like(self.nut_mm)

    def structure_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The plant's structure law, shifted by the creep deflection of the elements idx."""
        return super().structure_force(y - pick(self._x2, idx), idx)

    def step(self, motor_v: Any) -> None:
        """Step, then let the creep deflection follow the force carried."""
        super().step(motor_v)
        a = 1.0 - np.exp(-self.cfg.dt_s / self.tau)
        self._x2 = self._x2 + (self.shaft_force / self.k2 - self._x2) * a


class GroundShiftPot(Plant):
    """The pot's ground return shares a wire with the motor's: the motor current raises the pot's ground by
    R_g i (signed: pushing up, retracting down, no lag), which moves the wiper's voltage by (1 - x) R_g i, x
    the wiper's position on the track (its reading over the ADC's full scale). Stands in for the catalogue's
    pot voltage drop (which follows |i| through a lag)."""

    kappa = 400.0  # counts per unit current (normalised to stall) at x = 0

    def read(self):
        """The reading with the ground shift added."""
        s = super().read()
        x = s.pot / self.geo.adc_max
        shift = self.kappa * self.current * (1.0 - x)
        s.pot = np.clip(np.rint(s.pot + shift), 0, self.geo.adc_max).astype(np.int64)
        return s


class CableDrag(Plant):
    """A sensor cable tied along the linkage starts to rub on the housing once the linkage opens past theta_c:
    extra friction dF / (1 + exp(-(angle - theta_c) / w)) on the shaft, the same both ways (a smoothed step
    in the linkage angle), on top of the catalogue's linkage friction."""

    df, theta_c, w = 1.2, 16.0, 1.0  # N, deg, deg

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's friction plus the cable's rub at this linkage angle."""
        fwd, rev = super().friction_limits(angle_deg)
        rub = self.df / (1.0 + np.exp(-(angle_deg - self.theta_c) / self.w))
        return fwd + rub, rev + rub


class PotCouplingPlay(Plant):
    """Play in the set-screw coupling between the linkage's pivot and the pot's shaft: the pot's shaft
    follows the linkage angle with a dead band of +-delta degrees (it lags by delta once the linkage moves,
    on either side), so the pot reads low while the linkage opens and high while it closes."""

    delta = 0.4  # deg

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, with the pot's shaft centred in its play at home."""
        super().__init__(cfg, contact_deg, seed)
        self._seen = self._linkage_angle()

    def _linkage_angle(self) -> np.ndarray:
        """The angle of the linkage's pivot now (the structure deforms beyond the pivot)."""
        return self.geo.angle_from_shaft(np.minimum(self.shaft_mm, self.y_contact))

    def step(self, motor_v: Any) -> None:
        """Step, then drag the pot's shaft along where the play is taken up."""
        super().step(motor_v)
        a = self._linkage_angle()
        self._seen = np.minimum(np.maximum(self._seen, a - self.delta), a + self.delta)

    def read(self):
        """The reading at the pot shaft's angle instead of the linkage's."""
        s = super().read()
        g = self.geo
        lag = g.pot_from_angle(self._seen) - g.pot_from_angle(self._linkage_angle())
        s.pot = np.clip(np.rint(s.pot + lag), 0, g.adc_max).astype(np.int64)
        return s


class DitherFriction(_DutyPlant):
    """Dither: the H-bridge's PWM shakes the screw and the shaft's guide, which lowers the guide's Coulomb
    friction while the motor is driven: the catalogue's actuator friction times (1 - r D), D = |V| / V_supply
    the duty (pushes run at lower duty than retracts, so the two directions are lowered differently). The
    linkage's pivot is not reached by the vibration."""

    r = 0.45

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's friction less the dithered share of the actuator friction."""
        fwd, rev = super().friction_limits(angle_deg)
        af = self.cfg.effects.actuator_friction
        if not af.enabled:
            return fwd, rev
        cut = self.r * self._d * af.force_n
        return np.maximum(fwd - cut, 0.0), np.maximum(rev - cut * af.reverse_ratio, 0.0)


class RippleOffset(_DutyPlant):
    """The PWM ripple current in the motor leads couples into the load cell's leads and the amplifier's input
    stage rectifies it: a DC offset g 4 D (1 - D) on the reading (ripple amplitude ~ D (1 - D), D the duty),
    present while the motor is driven, largest at half duty, zero at rest."""

    g = 0.45  # N at D = 0.5

    def read(self):
        """The reading plus the rectified ripple."""
        s = super().read()
        s.load_cell_n = s.load_cell_n + self.g * 4.0 * self._d * (1.0 - self._d)
        s.force_n = s.load_cell_n / self.ratio
        return s


class MainsHum(Plant):
    """Mains hum picked up by the unshielded bridge leads: the load cell reads A sin(2 pi f s + phi) extra at
    session time s (f near 60 Hz, sampled at the loop rate: an aliased, zero-mean pattern)."""

    amp, freq, phase = 0.3, 60.0, 0.0  # N, Hz, rad

    def read(self):
        """The reading plus the hum at this instant of each trial's session time."""
        s = super().read()
        session = self.t + TRIAL_GAP_S * np.arange(s.load_cell_n.size)
        s.load_cell_n = s.load_cell_n + self.amp * np.sin(2 * np.pi * self.freq * session + self.phase)
        s.force_n = s.load_cell_n / self.ratio
        return s


class PotDropouts(Plant):
    """A worn pot track: while the wiper moves it lifts off now and then (probability p per sample), and the
    ADC's pull-down drags that sample's reading to a fraction u of its value (u uniform in 0..0.3)."""

    p = 0.06

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, and the dropouts' own generator (the plant's noise stream is left as it is)."""
        super().__init__(cfg, contact_deg, seed)
        self._drops = np.random.default_rng([seed, 0xD0])

    def read(self):
        """The reading, with this sample's dropouts where the wiper is moving."""
        s = super().read()
        lift, u = self._drops.random(s.pot.size), 0.3 * self._drops.random(s.pot.size)
        moving = (self.shaft_mm < self.y_contact) & (np.abs(self.v_shaft) > 0.5)
        drop = moving & (lift < self.p)
        s.pot = np.where(drop, np.rint(s.pot * u), s.pot).astype(np.int64)
        return s


# Expected names and reasons: fixed before any run of the workflow on these forms; do not edit after.
FORMS: dict[str, Form] = {
    "return_spring": Form(
        ReturnSpring,
        None,
        {"f_r": (1.0, 2.0), "k_r": (0.1, 0.3)},
        frozenset({"spring_preload"}),
        "a force on the shaft of one sign whatever the direction of motion, nearly constant: in the force "
        "balance it is a spring force offset (a negative F_0), the catalogue's preload",
    ),
    "film_lag_friction": Form(
        FilmLagFriction,
        None,
        {"df": (1.0, 2.0), "v_s": (1.0, 3.0), "tau": (0.02, 0.08)},
        frozenset({"stribeck_friction"}),
        "extra friction at low speed and at break-away that fades as the shaft speeds up: the catalogue's "
        "Stribeck term (here with a Lorentzian shape and a lag of the speed it reads)",
    ),
    "creeping_housing": Form(
        CreepingHousing,
        None,
        {"k2": (30.0, 60.0), "tau": (0.15, 0.5)},
        frozenset({"series_compliance"}),
        "extra deflection of the structure in series with the spring, beyond the pot, growing with the "
        "force: a recalibration of the present series compliance (softer), here with a creep lag",
    ),
    "ground_shift_pot": Form(
        GroundShiftPot,
        "pot_voltage_drop",
        {"kappa": (300.0, 500.0)},
        frozenset({"pot_voltage_drop"}),
        "a pot reading error driven by the motor current: the catalogue's only current-driven pot law "
        "(there with |i| and a lag, here signed and instant)",
    ),
    "cable_drag": Form(
        CableDrag,
        None,
        {"df": (0.8, 1.6), "theta_c": (12.0, 20.0), "w": (0.5, 1.5)},
        frozenset({"linkage_friction"}),
        "Coulomb friction on the shaft that depends on the linkage angle: a recalibration of the present "
        "linkage friction's angle law (a step instead of its quadratic)",
    ),
    "pot_coupling_play": Form(
        PotCouplingPlay,
        None,
        {"delta": (0.25, 0.5)},
        frozenset({"backlash"}),
        "a dead band taken up at every reversal between the drive and what the sensors say of the linkage "
        "(compression over-estimated opening, under-estimated closing): the catalogue's backlash",
    ),
    "dither_friction": Form(
        DitherFriction,
        None,
        {"r": (0.3, 0.6)},
        frozenset({"actuator_friction"}),
        "a Coulomb band on the guide, lowered per direction by the drive's duty (constant over a push or a "
        "retract, whatever the angle or position): a recalibration of the present actuator friction (its "
        "level and reverse ratio)",
    ),
    "ripple_offset": Form(
        RippleOffset,
        None,
        {"g": (0.3, 0.6)},
        frozenset({"load_cell_offset"}),
        "an additive error of one sign on the load-cell reading, the mechanics untouched, roughly constant "
        "while the motor runs: the catalogue's load-cell offset",
    ),
    "mains_hum": Form(
        MainsHum,
        None,
        {"amp": (0.2, 0.4), "freq": (59.6, 60.4), "phase": (0.0, 2 * np.pi)},
        frozenset(),
        "none: a zero-mean periodic interference on the load cell unrelated to the actuator's state; the "
        "catalogue's load-cell laws are a constant offset and a delay of the force, neither close",
    ),
    "pot_dropouts": Form(
        PotDropouts,
        None,
        {"p": (0.04, 0.08)},
        frozenset(),
        "none: sporadic gross pot outliers while the wiper moves; the catalogue's pot laws are a smooth "
        "current-driven drop and zero-mean Gaussian noise (a noise model, not in the catalogue named from)",
    ),
}


HARNESS = _a.Harness(FORMS)  # set A's harness on this set's forms
form_case, run_form, main = HARNESS.form_case, HARNESS.run_form, HARNESS.main
rates, table = _a.rates, _a.table


if __name__ == "__main__":
    raise SystemExit(main())
