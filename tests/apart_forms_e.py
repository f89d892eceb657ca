"""A fifth held-out set of effect forms written apart from the discrepancy naming rule (set E).

Written by a fifth separate author (the helper `formse`) who had not read the naming/claim rule and was told
not to: only the Plant interface and the catalogue's effect laws (seagen/plant/sim.py, config.py and
kernel.py's `available`), the trial protocol (seagen/data/protocol.py), the geometry (seagen/geometry.py), the
actuator description (seagen/actuators/paper.toml), the family module's conventions and forms
(seagen/discrepancy/families.py), sets A-D themselves (tests/apart_forms.py, apart_forms_b.py,
apart_forms_c.py, apart_forms_d.py; not their tests) and the design notes' actuator and catalogue sections
(/work/shared/DESIGN.md) were read; no other file of seagen/discrepancy/, no docs/, no test of the
discrepancy workflow or of the form sets, no git log about the discrepancy workflow, no issue text and no
earlier result. The workflow was not run on these forms by their author. Each form is a law a real SEA could
show, physically different from the catalogue's own laws, from the benchmark families and from sets A-D's
forty forms; six of the ten are laws of the mechanics (friction, forces on the shaft, the spring's path or
the drive).

The expected names were fixed, each with its physical reason, before any run of the workflow on these forms
(by anyone), and are not to be changed after seeing results. The expected name is the catalogue effect whose
law a physicist would change first to approximate the form's law. An empty `expected` means no catalogue
effect's law is close: the right answer there is "unexplained / closest, not claimed" (every claim at >= 0.9
counts as wrong).

Conventions as in sets A-D and families.py: a form that stands in for an effect the default plant enables
switches that effect off in both the truth and the base (`replaces`: the closest change is then an addition);
a form that acts on top of an enabled effect leaves it on (`replaces` None: the closest change is then a
recalibration of that effect); every other effect of the default plant stays as it is. Parameters are drawn
per seed from the stated ranges (plausible for the paper's actuator, visible above the sensor noise). Forms
with their own randomness draw it from a generator seeded by the plant's seed (the plant's own noise stream
is left as it is); no form of this set depends on session time. Every form overrides at least one of the
motion laws the compiled kernel checks (kernel.available reports it as not plain), so the plant's own Python
stepping runs it.

The harness (form_case, run_form, rates, table, main) is set A's, run on this set's FORMS:
    .venv/bin/python tests/apart_forms_e.py [--seeds N] [--forms a,b] [--quick] [--json rows.json]
"""

from __future__ import annotations

from typing import Any

import apart_forms as _a
import numpy as np
from apart_forms import Form

from seagen.plant import Plant, PlantConfig, pick


class PtfeGuide(Plant):
    """The output shaft runs in a PTFE-lined bushing, whose friction rises with the sliding speed (velocity
    strengthening, the reason PTFE does not stick-slip: break-away below the sliding level): the band
    f_s + df (1 - exp(-|v| / v0)), the same both ways, with v the shaft's speed over this step (implicit: the
    band read at the last step's speed made the massless shaft stick and slip every other step). Stands in for
    the catalogue's actuator friction (the guide's Coulomb band, lower in reverse)."""

    f_s, df, v0 = 1.6, 1.2, 0.1  # N, N, mm/s

    def _move_shaft(self, dt: float) -> None:
        """Quasi-static massless shaft: stick inside the plant's friction plus f_s, else slide by the unique
        step dy with net(y0 + dy) - drag = the plant's friction plus the band at speed |dy| / dt (net falls
        with y and the band rises with |dy|: bisection on |dy|, each element on its own)."""
        y0 = self.shaft_mm
        fwd, rev = self.friction_limits(self.geo.angle_from_shaft(np.minimum(y0, self.y_contact)))
        n0 = self._net_force(y0)[0]
        up, down = n0 > fwd + self.f_s, n0 < -(rev + self.f_s)
        y = y0.copy()
        idx = np.flatnonzero(up | down)
        if idx.size:
            sgn = np.where(up, 1.0, -1.0)[idx]
            other = np.where(up, fwd, rev)[idx] + self.f_s
            b = pick(self.viscous_n_s_per_mm(), idx) / dt
            lo = np.zeros(idx.size)
            hi = (np.abs(n0[idx]) - other) / self.k_spring + 1e-9  # net falls at least as fast as the spring
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                f = self._net_force(y0[idx] + sgn * mid, idx)[0]
                band = other + self.df * (1.0 - np.exp(-mid / (dt * self.v0)))
                beyond = sgn * f - b * mid - band > 0  # the root lies beyond mid
                lo, hi = np.where(beyond, mid, lo), np.where(beyond, hi, mid)
            y[idx] = y0[idx] + sgn * 0.5 * (lo + hi)
        self.v_shaft = (y - y0) / dt
        self.shaft_mm = y


class BellowsBoot(Plant):
    """A rubber dust boot over the output shaft, vented through a small hole: moving the shaft changes the
    boot's volume, the air is compressible and leaks through the vent, so the pressure force on the shaft
    follows a drag b v through the lag tau of the air spring and the vent (k_air = b / tau):
    dF/dt = (b v - F) / tau, F opposing the motion and relaxing at rest. Implicit per step: this step's force
    is a F_prev + c v, a = 1 / (1 + dt / tau), c = b (dt / tau) a (c v solved with the shaft like the
    catalogue's viscous term, a F_prev held)."""

    b, tau = 0.1, 0.025  # N s/mm, s

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, the boot at ambient pressure (F = 0)."""
        super().__init__(cfg, contact_deg, seed)
        self._p = np.zeros_like(self.nut_mm)

    def _lag(self) -> tuple[float, float]:
        """(a, c) of the implicit step."""
        r = self.cfg.dt_s / self.tau
        return 1.0 / (1.0 + r), self.b * r / (1.0 + r)

    def viscous_n_s_per_mm(self) -> float | np.ndarray:
        """The plant's viscous coefficient plus the boot's share of this step's drag."""
        return super().viscous_n_s_per_mm() + self._lag()[1]

    def _net_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The plant's net push on the shaft less the boot's held pressure force (elements idx)."""
        f, s = super()._net_force(y, idx)
        return f - self._lag()[0] * pick(self._p, idx), s

    def step(self, motor_v: Any) -> None:
        """Step, then update the boot's force with this step's shaft speed."""
        super().step(motor_v)
        a, c = self._lag()
        self._p = a * self._p + c * self.v_shaft

    def _move_shaft(self, dt: float) -> None:
        """Plant's shaft motion, which solves with the laws above (declared here so that this plant is not
        taken for one with Plant's own motion laws)."""
        super()._move_shaft(dt)


class FingerWeight(Plant):
    """The hand is held palm down: the weight of the finger segment and the linkage's arm helps the linkage
    close, a torque T_g cos(angle) about the pivot, reflected to the shaft by virtual work:
    F = T_g cos(angle) / (CB sin(angle)), pushing the shaft forward whichever way it moves; largest near home,
    ~4 times smaller at the top of the range, constant once the finger rests on the load cell (the angle
    stops at contact)."""

    t_g = 3.5  # N mm

    def _push(self, y: np.ndarray, idx: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """The weight's push on the shaft at advance y and its slope (elements idx)."""
        g = self.geo
        yc = pick(self.y_contact, idx)
        a = np.radians(np.maximum(g.angle_from_shaft(np.clip(y, 0.0, yc)), g.home_deg))
        lever = g.cb_mm * np.sin(a)  # dy/dangle, mm per rad
        f = self.t_g * np.cos(a) / lever
        slope = -self.t_g / (g.cb_mm * np.sin(a) ** 2) / lever  # d(cot)/dangle over dy/dangle
        return f, np.where((y > 0) & (y < yc), slope, 0.0)

    def _net_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The plant's net push on the shaft plus the weight's (and its slope, <= 0)."""
        f, s = super()._net_force(y, idx)
        w, ws = self._push(y, idx)
        return f + w, s + ws

    def _move_shaft(self, dt: float) -> None:
        """Plant's shaft motion, which solves with _net_force above (declared here so that this plant is not
        taken for one with Plant's own motion laws)."""
        super()._move_shaft(dt)


class BumpStop(Plant):
    """A rubber bump stop on the shaft inside the spring (it keeps the coils off their solid height): the nut
    reaches it at compression d_b, beyond which it adds c (d - d_b)^2 in parallel with the spring (rubber
    stiffens as it is squashed)."""

    d_b, c = 2.5, 1.2  # mm, N/mm^2

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The plant's spring plus the bump stop."""
        return super().spring_force(d, idx) + self.c * np.maximum(d - self.d_b, 0.0) ** 2

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The slope of spring_force."""
        return super()._spring_slope(d, idx) + 2.0 * self.c * np.maximum(d - self.d_b, 0.0)


class FloatingScrew(Plant):
    """The lead screw floats axially in its bearings, held forward by a preloaded wave washer: once the
    spring's load exceeds the washer's preload F_w the screw (and the nut on it) is pushed back toward the
    motor, by up to the float g, over a band of force of width ~4 w: nut = motor - g (s((F - F_w) / w) -
    s(-F_w / w)), s the logistic, F the spring's load of the last step. The motor, hence the encoder, does not
    move with it; the catalogue's backlash is off."""

    g, f_w, w = 0.18, 6.5, 1.1  # mm, N, N

    def _float(self, f: np.ndarray) -> np.ndarray:
        """How far the load f pushes the screw back (mm; 0 at f = 0)."""
        return self.g * (
            1.0 / (1.0 + np.exp(-(f - self.f_w) / self.w)) - 1.0 / (1.0 + np.exp(self.f_w / self.w))
        )

    def _move_nut(self) -> None:
        """The plant's nut, set back by the float under the last step's load."""
        load = self.spring_force(self.nut_mm - self.shaft_mm)
        super()._move_nut()
        self.nut_mm = self.nut_mm - self._float(load)

    def _move_shaft(self, dt: float) -> None:
        """Plant's shaft motion (declared here so that this plant is not taken for a plain one)."""
        super()._move_shaft(dt)


class StrapCapstan(Plant):
    """The glove's elastic strap (a nearly constant tension) runs over the finger's knuckle; the wrap angle
    grows as the linkage closes the finger, and the strap slides over the knuckle with capstan friction
    T0 (exp(mu phi) - 1). Reflected to the shaft: f_top (exp(a x) - 1) / (exp(a) - 1), x = (angle - min) /
    (max - min) over the linkage's range (a = mu phi at its top), the same both ways, on top of the
    catalogue's linkage friction."""

    f_top, a = 1.5, 1.8  # N at the top of the range, capstan exponent there

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's friction plus the strap's at this linkage angle."""
        fwd, rev = super().friction_limits(angle_deg)
        g = self.geo
        x = np.clip((angle_deg - g.angle_min_deg) / (g.angle_max_deg - g.angle_min_deg), 0.0, 1.0)
        band = self.f_top * np.expm1(self.a * x) / np.expm1(self.a)
        return fwd + band, rev + band


class BrushEmiPot(Plant):
    """The brushed motor's commutation spikes couple into the pot's high-impedance wiper line, and the ADC
    input's clamp and RC filter rectify them into a positive bias that grows with the spike rate, i.e. with
    the motor's speed: the pot reads g |v_motor| / v_max high, at once, and nothing while the motor stands
    (even under load). The pot's reference has its own regulator: stands in for the catalogue's pot voltage
    drop."""

    g = 160.0  # pot counts at the no-load speed

    def read(self):
        """The reading plus the rectified spikes."""
        s = super().read()
        bias = self.g * np.abs(self.v_motor) / self.v_max
        s.pot = np.clip(np.rint(s.pot + bias), 0, self.geo.adc_max).astype(np.int64)
        return s

    def _move_shaft(self, dt: float) -> None:
        """Plant's shaft motion (declared here so that this plant is not taken for a plain one)."""
        super()._move_shaft(dt)


class JitterCell(Plant):
    """The load cell's amplifier streams its conversions to the logger over a shared serial bus whose queue
    delays each one: a row carries the tip force of lag0 + E ago, E exponential with mean tau_j (in whole
    plant steps, at most MAX_S): a latency of lag0 + tau_j on average, with jitter. The noise is added after,
    as the plant's; the draws come from the form's own generator of the plant's seed."""

    lag0, tau_j = 0.01, 0.012  # s, s
    MAX_S = 0.1  # the queue's longest delay (s)

    def __init__(self, cfg: PlantConfig, contact_deg: Any, seed: int = 0) -> None:
        """The plant, the past tip forces at rest (zero) and the queue's generator."""
        super().__init__(cfg, contact_deg, seed)
        self._buf = np.zeros((int(round(self.MAX_S / cfg.dt_s)) + 1, self.nut_mm.size))
        self._k = 0
        self._queue = np.random.default_rng([seed, 0xE5])

    def step(self, motor_v: Any) -> None:
        """Step, then remember this step's tip force."""
        super().step(motor_v)
        self._k += 1
        self._buf[self._k % len(self._buf)] = self.shaft_force * self.ratio

    def read(self):
        """The reading with each element's queued (late) tip force instead of the tip force now."""
        s = super().read()
        n = s.load_cell_n.size
        late = self.lag0 + self._queue.exponential(self.tau_j, n)
        lag = np.minimum(np.rint(late / self.cfg.dt_s).astype(np.int64), len(self._buf) - 1)
        past = self._buf[(self._k - lag) % len(self._buf), np.arange(n)]
        tip = self._history[self._delay_n] * self.ratio
        s.load_cell_n = s.load_cell_n - tip + past
        s.force_n = s.load_cell_n / self.ratio
        return s


class CableStrainCell(Plant):
    """The load cell's cable is clipped to the linkage's arm: as the linkage opens, the cable bends and pulls
    at the cell's cable exit, straining the bridge: the reading gains c (angle - home) N, the angle the
    linkage's now (the pivot's: the structure deforms beyond it), whatever the force."""

    c = 0.03  # N per degree

    def read(self):
        """The reading plus the cable's strain."""
        s = super().read()
        g = self.geo
        angle = g.angle_from_shaft(np.minimum(self.shaft_mm, self.y_contact))
        s.load_cell_n = s.load_cell_n + self.c * np.maximum(angle - g.home_deg, 0.0)
        s.force_n = s.load_cell_n / self.ratio
        return s

    def _move_shaft(self, dt: float) -> None:
        """Plant's shaft motion (declared here so that this plant is not taken for a plain one)."""
        super()._move_shaft(dt)


class RollingContact(Plant):
    """The round fingertip (radius r_t) rolls on the load cell's plate as the contact angle changes, so the
    contact point lies r_t (angle - angle_cal) (in rad) along the plate from the point where the cell was
    calibrated; the cell is a bending beam whose gauges see the moment, so it reads the tip force times
    1 + r_t (angle - angle_cal) / L, L the calibration point's distance from the gauges: a gain error per
    contact angle, of either sign across the range, the mechanics untouched."""

    r_t, arm, cal = 8.0, 22.0, 16.0  # mm, mm, deg

    def read(self):
        """The reading with the tip force scaled by the contact point's lever."""
        s = super().read()
        gain = self.r_t * np.radians(self.contact_deg - self.cal) / self.arm
        tip = self._history[self._delay_n] * self.ratio
        s.load_cell_n = s.load_cell_n + gain * tip
        s.force_n = s.load_cell_n / self.ratio
        return s

    def _move_shaft(self, dt: float) -> None:
        """Plant's shaft motion (declared here so that this plant is not taken for a plain one)."""
        super()._move_shaft(dt)


# Expected names and reasons: fixed before any run of the workflow on these forms; do not edit after.
FORMS: dict[str, Form] = {
    "ptfe_guide": Form(
        PtfeGuide,
        "actuator_friction",
        {"f_s": (1.2, 2.0), "df": (0.8, 1.5), "v0": (0.05, 0.2)},
        frozenset({"actuator_friction"}),
        "a friction band on the shaft, the same at every angle, that is at its full level at every speed the "
        "protocol slides at (v0 is a fraction of a mm/s): the catalogue's Coulomb actuator friction (here "
        "symmetric, and a little lower only at break-away)",
    ),
    "bellows_boot": Form(
        BellowsBoot,
        None,
        {"b": (0.06, 0.15), "tau": (0.015, 0.04)},
        frozenset({"viscous_friction"}),
        "a force on the shaft opposing its motion, growing with its speed and relaxing to zero at rest: the "
        "catalogue's viscous drag (here reached through the lag of the air in the boot)",
    ),
    "finger_weight": Form(
        FingerWeight,
        None,
        {"t_g": (2.5, 5.0)},
        frozenset({"spring_preload"}),
        "a force on the shaft of one sign whatever the direction of motion (pushing it forward, constant at "
        "each contact): in the force balance a spring force offset (a positive F0), the catalogue's preload "
        "(here falling with the contact angle)",
    ),
    "bump_stop": Form(
        BumpStop,
        None,
        {"d_b": (2.0, 3.0), "c": (0.8, 1.6)},
        frozenset({"spring_nonlinearity"}),
        "a force between nut and shaft growing faster than linearly with the compression at large "
        "compressions: the catalogue's progressive (hardening) spring law (cubic there, a squared gap here)",
    ),
    "floating_screw": Form(
        FloatingScrew,
        None,
        {"g": (0.10, 0.25), "f_w": (5.0, 8.0), "w": (0.8, 1.4)},
        frozenset({"series_compliance"}),
        "extra encoder travel per newton, only under contact loads and unseen by the pot (the shaft stands "
        "at contact): the signature of deflection in series with the spring, a recalibration of the present "
        "series compliance (here between the motor and the nut, taken up over a band of force)",
    ),
    "strap_capstan": Form(
        StrapCapstan,
        None,
        {"f_top": (1.0, 2.0), "a": (1.0, 2.5)},
        frozenset({"linkage_friction"}),
        "Coulomb friction on the shaft, the same both ways, that grows with the linkage angle: a "
        "recalibration of the present linkage friction's angle law (exponential here, quadratic there)",
    ),
    "brush_emi_pot": Form(
        BrushEmiPot,
        "pot_voltage_drop",
        {"g": (100.0, 220.0)},
        frozenset({"pot_voltage_drop"}),
        "the pot reads high while the motor runs and settles when it stops: the catalogue's pot voltage drop "
        "(driven by |current| through a lag there, by |speed| at once here; DESIGN allows either)",
    ),
    "jitter_cell": Form(
        JitterCell,
        None,
        {"lag0": (0.005, 0.015), "tau_j": (0.005, 0.02)},
        frozenset({"transport_delay"}),
        "the load cell reads the force late by 10-35 ms on average: the catalogue's transport delay (here "
        "with a random spread from sample to sample)",
    ),
    "cable_strain_cell": Form(
        CableStrainCell,
        None,
        {"c": (0.02, 0.04)},
        frozenset({"load_cell_offset"}),
        "an additive error of one sign on the load-cell reading, present with or without force, the "
        "mechanics untouched: the catalogue's load-cell zero offset (here growing with the linkage angle)",
    ),
    "rolling_contact": Form(
        RollingContact,
        None,
        {"r_t": (6.0, 10.0), "arm": (15.0, 30.0), "cal": (12.0, 20.0)},
        frozenset(),
        "none: a load-cell gain error that depends on the contact angle and changes sign across the range "
        "(proportional to the force, zero at rest); the catalogue's load-cell law is an additive offset, its "
        "spring and structure laws are the same at every angle, and friction changes sign with the motion",
    ),
}


HARNESS = _a.Harness(FORMS)  # set A's harness on this set's forms
form_case, run_form, main = HARNESS.form_case, HARNESS.run_form, HARNESS.main
rates, table = _a.rates, _a.table


if __name__ == "__main__":
    raise SystemExit(main())
