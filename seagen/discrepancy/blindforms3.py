"""Blind set 3 (issue 39 item 3): hidden-effect forms written apart from the term library, with expectations.

Each form is a truth plant (a Plant subclass adding its own law to the design's default plant, or
distorting what a sensor reads) whose physical parameters are drawn per case (per seed) from the ranges
stated below. The truth config and the base config are both the design's own default plant: nothing in the
config is hidden, the effect lives only in the class. For every form the expected class, the channel(s)
it acts on ("force": the load cell; "position": encoder and/or pot; "both") and the true values of its key
parameters (units in the key names) were written here before any run of the discovery.

Designs: the paper's default, and examples/actuators/{stiff_24v,micro_6v,fast_48v}.toml.

Each form's effect on the logged signals (effect_rms; `python -m seagen.discrepancy.blindforms3`): a short
session of the protocol (bench.measure, fast) from the truth plant, its logged command replayed open loop
through the truth plant and through the base plant with the same seed (the same sensor noise); RMS of the
difference over the logged rows, in the design's own sensor sigmas (sensor_sigma: encoder and pot rounding
1/sqrt(12) count, pot noise, the load cell mount's sigma), seeds 0 / 1 / 2. The encoder's sigma is its
rounding alone (0.29 count), so any change of the motion shows there as a large number (nonlin_stiffness:
nonlinear_stiffness).

| form | design | class | enc | pot | load_cell_n |
| --- | --- | --- | ---: | ---: | ---: |
| screw_pitch_error | default | periodic | 3.6 / 4.3 / 3.0 | 2.2 / 1.1 / 1.3 | 2.1 / 2.2 / 1.6 |
| carrier_runout | fast_48v | periodic | 8.1 / 10.4 / 11.0 | 0.6 / 0.6 / 0.4 | 0.9 / 1.2 / 1.3 |
| pot_track_ripple | stiff_24v | periodic | 0.0 / 0.0 / 0.0 | 2.5 / 1.5 / 2.1 | 0.0 / 0.0 / 0.0 |
| bearing_defect | stiff_24v | periodic | 519.4 / 461.0 / 676.5 | 1.4 / 1.6 / 2.1 | 2.7 / 2.6 / 3.4 |
| pot_supply_sag | micro_6v | drift | 0.0 / 0.0 / 0.0 | 2.1 / 2.5 / 2.4 | 0.0 / 0.0 / 0.0 |
| grease_run_in | default | drift | 24.5 / 26.9 / 34.9 | 4.2 / 4.9 / 6.1 | 4.3 / 4.6 / 6.0 |
| motor_heat_cell_zero | fast_48v | drift | 0.0 / 0.0 / 0.0 | 0.0 / 0.0 / 0.0 | 2.9 / 2.9 / 1.5 |
| load_friction | default | state_friction | 47.6 / 28.3 / 20.3 | 2.0 / 1.4 / 1.0 | 10.1 / 6.3 / 4.7 |
| screw_misalignment | fast_48v | state_friction | 63.7 / 29.0 / 85.9 | 0.2 / 0.3 / 0.2 | 3.1 / 1.2 / 4.2 |
| ageing_friction | default | state_friction | 7.9 / 2.0 / 2.0 | 6.5 / 2.1 / 2.2 | 1.7 / 0.3 / 0.4 |
| cell_play_hysteresis | default | hysteresis | 0.0 / 0.0 / 0.0 | 0.0 / 0.0 / 0.0 | 2.7 / 3.1 / 3.5 |
| iwan_spring | micro_6v | hysteresis | 164.4 / 220.7 / 110.2 | 3.1 / 4.0 / 2.1 | 3.4 / 4.6 / 2.3 |
| coil_seating | stiff_24v | nonlin_stiffness | 1200.9 / 844.0 / 1646.2 | 0.7 / 0.4 / 0.9 | 5.0 / 3.5 / 6.9 |
| cell_filter2 | fast_48v | sensor_lag | 0.0 / 0.0 / 0.0 | 0.0 / 0.0 / 0.0 | 36.8 / 23.8 / 23.2 |
| cell_quantised | micro_6v | quantisation | 0.0 / 0.0 / 0.0 | 0.0 / 0.0 / 0.0 | 2.8 / 2.4 / 1.9 |
| drive_current_limit | stiff_24v | saturation | 6165 / 3909 / 4085 | 5.0 / 3.2 / 3.3 | 5.8 / 3.9 / 4.0 |
| wiper_dropouts | micro_6v | other | 0.0 / 0.0 / 0.0 | 9.0 / 8.8 / 9.9 | 0.0 / 0.0 / 0.0 |
| current_crosstalk | default | other | 0.0 / 0.0 / 0.0 | 0.0 / 0.0 / 0.0 | 2.4 / 3.4 / 3.7 |
| cell_span_error | default | other | 0.0 / 0.0 / 0.0 | 0.0 / 0.0 / 0.0 | 6.1 / 6.2 / 5.4 |
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from seagen import fmath
from seagen.actuator import Actuator, default_actuator, load_actuator
from seagen.plant import Plant, PlantConfig, pick

CLASSES = frozenset(
    {
        "periodic",
        "drift",
        "state_friction",
        "hysteresis",
        "nonlinear_stiffness",
        "sensor_lag",
        "quantisation",
        "saturation",
        "other",
    }
)
CHANNELS = frozenset({"force", "position", "both"})
DESIGNS = ("default", "stiff_24v", "micro_6v", "fast_48v")
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "actuators"


def design_actuator(design: str) -> Actuator:
    """The actuator description of `design` ("default": the paper's; else examples/actuators/NAME.toml)."""
    if design not in DESIGNS:
        raise KeyError(f"unknown design {design!r}; known: {', '.join(DESIGNS)}")
    return default_actuator() if design == "default" else load_actuator(EXAMPLES / f"{design}.toml")


def _cell(s: Any, plant: Plant, reading: np.ndarray) -> Any:
    """Sensors s with the load cell reading replaced (and the shaft force derived from it again)."""
    s.load_cell_n = reading
    s.force_n = reading / plant.ratio
    return s


def _sin(x: Any) -> Any:
    """sin(x) through the C library's cos (seagen.fmath: the same digits on every CPU)."""
    return fmath.cos(x - 0.5 * np.pi)


def _tip(plant: Plant) -> np.ndarray:
    """The noise-free tip force the load cell would read now (the plant's structure force times R_l)."""
    return plant.structure_force(plant.shaft_mm)[0] * plant.ratio


# --- periodic in position ---------------------------------------------------------------------------------
class ScrewPitchError(Plant):
    """Lead screw pitch error (paper's design): the nut runs ahead of / behind where the motor turn puts it by
    a periodic error of the thread, e(x) = A (sin th + h2 sin(2 th + phi2)), th = 2 pi x / P + phi, x the
    nut's nominal travel; the encoder on the motor does not see it, the spring does."""

    period_mm: float
    amplitude_mm: float
    phase_rad: float
    harmonic2_share: float
    phase2_rad: float

    def _lead(self) -> np.ndarray:
        x = super()._lead()
        th = 2 * np.pi * self.motor_mm / self.period_mm + self.phase_rad
        return x + self.amplitude_mm * (_sin(th) + self.harmonic2_share * _sin(2 * th + self.phase2_rad))


class CarrierRunout(Plant):
    """Planetary carrier eccentricity (fast_48v): the gearbox output turns unevenly, once per output turn, so
    the nut lags and leads the motor by e = A cos(2 pi x / lead + phi), period exactly the screw's lead."""

    period_mm: float
    amplitude_mm: float
    phase_rad: float

    def _lead(self) -> np.ndarray:
        x = super()._lead()
        return x + self.amplitude_mm * fmath.cos(2 * np.pi * self.motor_mm / self.period_mm + self.phase_rad)


class PotTrackRipple(Plant):
    """Conductive-plastic pot track ripple (stiff_24v): the wiper's reading deviates from linear by a ripple
    periodic in the wiper angle, A sin(2 pi angle / P + phi) counts (a track printed in segments)."""

    period_deg: float
    amplitude_counts: float
    phase_rad: float

    def read(self):
        s = super().read()
        ang = self.geo.angle_from_shaft(np.minimum(self.shaft_mm, self.y_contact))
        ripple = self.amplitude_counts * _sin(2 * np.pi * ang / self.period_deg + self.phase_rad)
        s.pot = np.clip(np.rint(s.pot + ripple), 0, self.geo.adc_max).astype(np.int64)
        return s


class BearingDefect(Plant):
    """A dented race in the screw's thrust bearing (stiff_24v): each ball crossing the dent adds a short
    friction bump, F = A ((1 + cos th) / 2)^6, th = 2 pi x / P + phi with x the nut's travel and P the
    travel per ball pass (the lead over the ball-pass count per turn)."""

    period_mm: float
    amplitude_n: float
    phase_rad: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fwd, rev = super().friction_limits(angle_deg)
        th = 2 * np.pi * self.nut_mm / self.period_mm + self.phase_rad
        bump = self.amplitude_n * ((1 + fmath.cos(th)) / 2) ** 6
        return fwd + bump, rev + bump


# --- drifting --------------------------------------------------------------------------------------------
class PotSupplySag(Plant):
    """The pot divider's supply regulator warming up (micro_6v): the pot is not ratiometric to the ADC, so its
    reading scales with a supply that falls by share (1 - exp(-t / tau)) after the trial starts."""

    share: float
    tau_s: float

    def read(self):
        s = super().read()
        g = 1.0 - self.share * (1.0 - math.exp(-self.t / self.tau_s))
        s.pot = np.clip(np.rint(s.pot * g), 0, self.geo.adc_max).astype(np.int64)
        return s


class GreaseRunIn(Plant):
    """Cold, stiff grease in the nut (paper's design): after the rest before a trial the screw's friction is
    higher by F_r and falls back as the grease is worked, F_r exp(-t / tau), both directions."""

    extra_n: float
    tau_s: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fwd, rev = super().friction_limits(angle_deg)
        extra = self.extra_n * math.exp(-self.t / self.tau_s)
        return fwd + extra, rev + extra


class MotorHeatCellZero(Plant):
    """Load-cell zero shifted by the motor's heat (fast_48v): the copper loss i^2 warms a thermal node with
    time constant tau (T' = (i^2 - T) / tau, T = 1 at steady stall current; the motor's continuous rating is
    near T = 0.01-0.02), and the cell's zero moves by c T newtons (c of either sign)."""

    n_per_unit_heat: float
    tau_s: float

    def step(self, motor_v: Any) -> None:
        super().step(motor_v)
        heat = getattr(self, "_heat", np.zeros_like(self.current))
        a = 1.0 - math.exp(-self.cfg.dt_s / self.tau_s)
        self._heat = heat + a * (self.current * self.current - heat)

    def read(self):
        s = super().read()
        heat = getattr(self, "_heat", np.zeros_like(s.load_cell_n))
        return _cell(s, self, s.load_cell_n + self.n_per_unit_heat * heat)


# --- state-dependent friction ----------------------------------------------------------------------------
class LoadFriction(Plant):
    """Screw friction growing with the axial load (paper's design): the thread's friction is mu times the
    spring force the nut carries (a lead screw's efficiency loss), in both directions."""

    mu: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fwd, rev = super().friction_limits(angle_deg)
        load = np.maximum(self.spring_force(self.nut_mm - self.shaft_mm), 0.0)
        return fwd + self.mu * load, rev + self.mu * load


class AgeingFriction(Plant):
    """Static friction that ages while the shaft rests (paper's design; rate-and-state): a state a grows
    toward 1 as 1 - exp(-t_stuck / tau) while the shaft sticks and is wiped out over a slip length d_c once it
    slides (a <- a exp(-|dy| / d_c)); the extra break-away friction is F_a a, both directions."""

    extra_n: float
    age_tau_s: float
    slip_mm: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fwd, rev = super().friction_limits(angle_deg)
        age = getattr(self, "_age", np.zeros_like(fwd))
        return fwd + self.extra_n * age, rev + self.extra_n * age

    def step(self, motor_v: Any) -> None:
        y0 = self.shaft_mm.copy()
        super().step(motor_v)
        dy = np.abs(self.shaft_mm - y0)
        age = getattr(self, "_age", np.zeros_like(dy))
        grow = age + (1.0 - age) * (1.0 - math.exp(-self.cfg.dt_s / self.age_tau_s))
        self._age = np.where(dy > 1e-7, age * fmath.exp(-dy / self.slip_mm), grow)


class ScrewMisalignment(Plant):
    """A screw mounted out of line with its nut's guide (fast_48v): the nut binds more the farther it runs
    from where the two line up, extra friction F_m ((x - x0) / 10 mm)^2 in both directions, x the nut's
    travel from home."""

    extra_n: float
    aligned_mm: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fwd, rev = super().friction_limits(angle_deg)
        u = (self.nut_mm - self.aligned_mm) / 10.0
        return fwd + self.extra_n * u * u, rev + self.extra_n * u * u


# --- hysteretic ------------------------------------------------------------------------------------------
class CellPlayHysteresis(Plant):
    """Load-cell hysteresis (paper's design; a cheap beam cell's glue and flexure): three play operators of
    widths w/3, 2w/3, w on the tip force, the reading lagging the force by up to H newtons (sum of the
    plays' deviations, H at full reversal)."""

    half_height_n: float
    width_n: float

    def read(self):
        s = super().read()
        x = _tip(self)
        widths = self.width_n * np.array([1 / 3, 2 / 3, 1.0])
        if getattr(self, "_plays", None) is None:
            self._plays = [x.copy() for _ in widths]
        dev = np.zeros_like(x)
        for j, w in enumerate(widths):
            self._plays[j] = np.minimum(np.maximum(self._plays[j], x - w), x + w)
            dev += (self._plays[j] - x) / w
        return _cell(s, self, s.load_cell_n + self.half_height_n * dev / len(widths))


class IwanSpring(Plant):
    """A spring with internal friction (micro_6v; coils rubbing on a guide): three Jenkins elements (a
    stiffness in series with a slider) in parallel with the spring, sliding at w/3, 2w/3, w of relative
    compression, together adding at most F_i newtons: smooth hysteresis loops in force vs compression."""

    friction_n: float
    slip_mm: float

    def _elements(self) -> list[tuple[float, float]]:
        """(stiffness N/mm, half width mm) of each Jenkins element."""
        ws = [self.slip_mm * f for f in (1 / 3, 2 / 3, 1.0)]
        return [(self.friction_n / 3 / w, w) for w in ws]

    def _slips(self) -> list[np.ndarray]:
        if getattr(self, "_sl", None) is None:
            self._sl = [np.zeros_like(self.nut_mm) for _ in range(3)]
        return self._sl

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        f = super().spring_force(d, idx)
        for (k, w), s in zip(self._elements(), self._slips(), strict=True):
            f = f + k * np.minimum(np.maximum(d - pick(s, idx), -w), w)
        return f

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        s0 = super()._spring_slope(d, idx)
        for (k, w), s in zip(self._elements(), self._slips(), strict=True):
            s0 = s0 + np.where(np.abs(d - pick(s, idx)) < w, k, 0.0)
        return s0

    def step(self, motor_v: Any) -> None:
        super().step(motor_v)
        d = self.nut_mm - self.shaft_mm
        self._sl = [
            np.minimum(np.maximum(s, d - w), d + w)
            for (_, w), s in zip(self._elements(), self._slips(), strict=True)
        ]


# --- nonlinear stiffness ---------------------------------------------------------------------------------
class CoilSeating(Plant):
    """End coils seating (stiff_24v): beyond an onset compression the closed end coils stop working and the
    spring stiffens, extra force k2 (d - d_on)^2 / 2 (stiffness rising linearly from the onset)."""

    onset_mm: float
    k2_n_per_mm2: float

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        e = np.maximum(d - self.onset_mm, 0.0)
        return super().spring_force(d, idx) + 0.5 * self.k2_n_per_mm2 * e * e

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        return super()._spring_slope(d, idx) + self.k2_n_per_mm2 * np.maximum(d - self.onset_mm, 0.0)


# --- sensor lag, quantisation, saturation ----------------------------------------------------------------
class CellFilter2(Plant):
    """The load-cell amplifier's second-order anti-alias filter (fast_48v): the tip force passes a low pass
    of cutoff f_c and damping zeta (x'' = w^2 (F - x) - 2 zeta w x', stepped at the plant's 1 kHz), the
    amplifier's noise after it. Its low-frequency delay is 2 zeta / w."""

    cutoff_hz: float
    damping: float

    def step(self, motor_v: Any) -> None:
        super().step(motor_v)
        f = _tip(self)
        x = getattr(self, "_fx", f * 0.0)
        v = getattr(self, "_fv", f * 0.0)
        w, dt = 2 * np.pi * self.cutoff_hz, self.cfg.dt_s
        for _ in range(4):  # four sub-steps (semi-implicit Euler) per plant step
            v = v + (dt / 4) * (w * w * (f - x) - 2 * self.damping * w * v)
            x = x + (dt / 4) * v
        self._fx, self._fv = x, v

    def read(self):
        s = super().read()
        x = getattr(self, "_fx", None)
        if x is None:
            return s
        return _cell(s, self, s.load_cell_n - _tip(self) + x)


class CellQuantised(Plant):
    """A coarse load-cell ADC (micro_6v; a 10-bit converter across a +-200 to +-350 N cell): the noisy
    reading rounded to steps of q newtons."""

    step_n: float

    def read(self):
        s = super().read()
        return _cell(s, self, self.step_n * np.rint(s.load_cell_n / self.step_n))


class DriveCurrentLimit(Plant):
    """The H-bridge's current limit (stiff_24v): the driver cuts the voltage so the motor current stays within
    +-i_lim (a share of the stall current at the supply): the volts reaching the motor are clamped to
    supply (v / v_max +- i_lim), a speed-dependent voltage limit."""

    current_limit: float

    def step(self, motor_v: Any) -> None:
        m = self.motor
        back = m.supply_v * self.v_motor / self.v_max
        lim = m.supply_v * self.current_limit
        volts = np.broadcast_to(np.asarray(motor_v, float), self.v_motor.shape)
        super().step(np.minimum(np.maximum(volts, back - lim), back + lim))


# --- none of these cleanly ---------------------------------------------------------------------------------
class WiperDropouts(Plant):
    """A pot wiper that lifts off the track while the linkage moves (micro_6v): each sample, with probability
    p min(|v| / v_ref, 1) (v the shaft's speed), the reading falls to a random 30-90 % of its value."""

    rate: float
    v_ref_mm_s: float
    draw_seed: int

    def read(self):
        s = super().read()
        if getattr(self, "_wrng", None) is None:
            self._wrng = np.random.default_rng(self.draw_seed)
        p = self.rate * np.minimum(np.abs(self.v_shaft) / self.v_ref_mm_s, 1.0)
        lift = self._wrng.random(p.size) < p
        frac = self._wrng.uniform(0.3, 0.9, p.size)
        s.pot = np.where(lift, np.rint(s.pot * frac).astype(np.int64), s.pot)
        return s


class CurrentCrosstalk(Plant):
    """Motor current coupling into the load-cell amplifier (paper's design; shared ground return): the
    reading moves by c times the signed motor current (normalised to stall at the supply)."""

    n_per_unit_current: float

    def read(self):
        s = super().read()
        return _cell(s, self, s.load_cell_n + self.n_per_unit_current * self.current)


class CellSpanError(Plant):
    """A mis-calibrated load-cell span (paper's design): the reading is (1 + g) times the force (g a few per
    cent, either sign), the zero right."""

    gain_error: float

    def read(self):
        s = super().read()
        return _cell(s, self, s.load_cell_n + self.gain_error * _tip(self))


@dataclass(frozen=True)
class Form:
    """A blind form: its law, design, parameter ranges (uniform), fixed and random-sign parameters, and the
    expectations committed before any run."""

    cls: type[Plant]
    design: str
    expected_class: str
    channels: str
    ranges: dict[str, tuple[float, float]]
    fixed: dict[str, float] = field(default_factory=dict)
    signed: tuple[str, ...] = ()  # parameters whose sign is drawn (+ or -) after the magnitude
    seeds: tuple[str, ...] = ()  # integer seeds of the form's own random draws (not physical)
    derived: dict[str, Callable[[dict[str, float]], float]] = field(default_factory=dict)  # more truth


TWO_PI = 2 * math.pi
FORMS: dict[str, Form] = {
    # periodic in position
    "screw_pitch_error": Form(
        ScrewPitchError,
        "default",
        "periodic",
        "force",
        {
            "period_mm": (4.0, 6.5),  # the thread's pitch on a multi-start 20 mm lead screw
            "amplitude_mm": (0.05, 0.1),  # a cheap trapezoidal screw and nut's periodic error, 50-100 um
            "phase_rad": (0.0, TWO_PI),
            "harmonic2_share": (0.2, 0.5),
            "phase2_rad": (0.0, TWO_PI),
        },
    ),
    "carrier_runout": Form(
        CarrierRunout,
        "fast_48v",
        "periodic",
        "force",
        {"amplitude_mm": (0.015, 0.035), "phase_rad": (0.0, TWO_PI)},  # 15-35 um of carrier eccentricity
        fixed={"period_mm": 5.0},  # once per gearbox output turn: the 5 mm lead
    ),
    "pot_track_ripple": Form(
        PotTrackRipple,
        "stiff_24v",
        "periodic",
        "position",
        {"period_deg": (2.5, 5.0), "amplitude_counts": (20.0, 40.0), "phase_rad": (0.0, TWO_PI)},
    ),
    "bearing_defect": Form(
        BearingDefect,
        "stiff_24v",
        "periodic",
        "force",
        {"period_mm": (0.9, 1.6), "amplitude_n": (0.6, 1.4), "phase_rad": (0.0, TWO_PI)},
    ),
    # drifting
    "pot_supply_sag": Form(
        PotSupplySag, "micro_6v", "drift", "position", {"share": (0.015, 0.04), "tau_s": (2.0, 6.0)}
    ),
    "grease_run_in": Form(
        GreaseRunIn, "default", "drift", "force", {"extra_n": (0.8, 1.6), "tau_s": (0.6, 1.5)}
    ),
    "motor_heat_cell_zero": Form(
        MotorHeatCellZero,
        "fast_48v",
        "drift",
        "force",
        {"n_per_unit_heat": (30.0, 60.0), "tau_s": (0.3, 1.0)},
        signed=("n_per_unit_heat",),
    ),
    # state-dependent friction
    "load_friction": Form(LoadFriction, "default", "state_friction", "force", {"mu": (0.05, 0.12)}),
    "screw_misalignment": Form(
        ScrewMisalignment,
        "fast_48v",
        "state_friction",
        "force",
        {"extra_n": (2.0, 5.0), "aligned_mm": (0.0, 4.0)},
    ),
    "ageing_friction": Form(
        AgeingFriction,
        "default",
        "state_friction",
        "both",  # before contact the stuck shaft shows on the pot, in contact on the load cell
        {"extra_n": (1.0, 2.5), "age_tau_s": (0.02, 0.1), "slip_mm": (0.02, 0.08)},
    ),
    # hysteretic
    "cell_play_hysteresis": Form(
        CellPlayHysteresis,
        "default",
        "hysteresis",
        "force",
        {"half_height_n": (0.12, 0.3), "width_n": (1.0, 3.0)},
    ),
    "iwan_spring": Form(
        IwanSpring, "micro_6v", "hysteresis", "force", {"friction_n": (0.3, 0.7), "slip_mm": (0.2, 0.8)}
    ),
    # nonlinear stiffness
    "coil_seating": Form(
        CoilSeating,
        "stiff_24v",
        "nonlinear_stiffness",
        "force",
        {"onset_mm": (0.35, 0.7), "k2_n_per_mm2": (1.5, 4.0)},
    ),
    # sensor lag, quantisation, saturation
    "cell_filter2": Form(
        CellFilter2,
        "fast_48v",
        "sensor_lag",
        "force",
        {"cutoff_hz": (15.0, 40.0), "damping": (0.6, 0.9)},
        derived={"lag_s": lambda p: 2 * p["damping"] / (2 * math.pi * p["cutoff_hz"])},  # low-frequency delay
    ),
    "cell_quantised": Form(CellQuantised, "micro_6v", "quantisation", "force", {"step_n": (0.35, 0.7)}),
    "drive_current_limit": Form(
        DriveCurrentLimit, "stiff_24v", "saturation", "both", {"current_limit": (0.15, 0.3)}
    ),
    # none of these cleanly
    "wiper_dropouts": Form(
        WiperDropouts,
        "micro_6v",
        "other",
        "position",
        {"rate": (0.02, 0.06), "v_ref_mm_s": (0.5, 1.5)},
        seeds=("draw_seed",),
    ),
    "current_crosstalk": Form(
        CurrentCrosstalk,
        "default",
        "other",
        "force",
        {"n_per_unit_current": (1.5, 3.0)},
        signed=("n_per_unit_current",),
    ),
    "cell_span_error": Form(
        CellSpanError, "default", "other", "force", {"gain_error": (0.03, 0.07)}, signed=("gain_error",)
    ),
}
BLIND_FORMS: tuple[str, ...] = tuple(FORMS)


def draw(name: str, seed: int) -> dict[str, float]:
    """The physical parameters of form `name` for case `seed` (uniform in its ranges, signs drawn)."""
    form = FORMS[name]
    rng = np.random.default_rng([seed, zlib.crc32(name.encode()), 3])  # stable as forms are added
    p: dict[str, Any] = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in form.ranges.items()}
    for k in form.signed:
        p[k] *= float(rng.choice([-1.0, 1.0]))
    for k in form.seeds:
        p[k] = int(rng.integers(1 << 31))
    return {**p, **form.fixed}


def blind_case(name: str, seed: int) -> tuple[type[Plant], PlantConfig, PlantConfig, dict]:
    """(truth plant class, truth config, base config, {"expected_class", "channels", "truth", "design"}) of
    form `name` in case `seed`; both configs are the design's own default plant (the effect is the
    class's)."""
    if name not in FORMS:
        raise KeyError(f"unknown blind form {name!r}; known: {', '.join(BLIND_FORMS)}")
    form = FORMS[name]
    params = draw(name, seed)
    cls = type(f"{form.cls.__name__}_{seed}", (form.cls,), dict(params))
    cfg = PlantConfig(actuator=design_actuator(form.design))
    truth = {k: v for k, v in params.items() if k not in form.seeds}
    truth |= {k: float(f(params)) for k, f in form.derived.items()}
    info = {
        "expected_class": form.expected_class,
        "channels": form.channels,
        "truth": truth,
        "design": form.design,
    }
    return cls, cfg, cfg, info


def replay(cls: type[Plant], cfg: PlantConfig, runs: Any, seed: int) -> dict[str, np.ndarray]:
    """The logged command of `runs` (seagen's own session of cfg's design) driven open loop through plant
    class cls (seed `seed`), each channel read on every logged row: {channel: (n_trials, T)}."""
    from seagen.data.protocol import sample_every
    from seagen.discrepancy.replay import drive

    u = drive(runs, cfg.dt_s)
    every = sample_every(cfg)
    plant = cls(cfg, runs.angle, seed=seed)
    n, rows = runs.mask.shape
    out = {c: np.zeros((n, rows)) for c in SIGNALS}
    for k in range(rows * every):
        if k % every == 0:
            s = plant.read()
            for c in SIGNALS:
                out[c][:, k // every] = getattr(s, c)
        plant.step(u[:, min(k, u.shape[1] - 1)])
    return out


SIGNALS = ("enc", "pot", "load_cell_n")


def sensor_sigma(cfg: PlantConfig, angle_deg: np.ndarray) -> dict[str, np.ndarray]:
    """The design's own sensor noise per trial (contact angles angle_deg): the encoder's and pot's rounding
    (1/sqrt(12) count), the pot's noise, the load cell's mount's sigma."""
    e, lc = cfg.effects, cfg.load_cells
    rounding = 1.0 / math.sqrt(12.0)
    pot = math.hypot(e.pot_noise.sigma_counts if e.pot_noise.enabled else 0.0, rounding)
    split = cfg.actuator.linkage.split_deg
    cell = np.where(angle_deg <= split, lc.horizontal_sigma_n, lc.vertical_sigma_n)
    return {
        "enc": np.full(angle_deg.shape, rounding),
        "pot": np.full(angle_deg.shape, pot),
        "load_cell_n": cell,
    }


def effect_rms(name: str, seed: int) -> dict[str, float]:
    """RMS change (in the design's sensor noise sigmas, sensor_sigma) per logged channel that form `name`
    (case `seed`) makes: a short session of the protocol (bench.measure, fast) from the truth plant, its
    command replayed through the truth plant and through the base plant with the same seed (the same sensor
    noise), differenced over the logged rows."""
    from seagen.discrepancy.bench import measure

    cls, truth, base, _ = blind_case(name, seed)
    runs = measure(truth, seed=seed, fast=True, plant_cls=cls)
    a, b = replay(cls, truth, runs, seed), replay(Plant, base, runs, seed)
    sig = sensor_sigma(base, np.asarray(runs.angle, float))
    out = {}
    for c in SIGNALS:
        z = (a[c] - b[c]) / sig[c][:, None]
        out[c] = float(np.sqrt(np.mean(z[runs.mask] ** 2)))
    return out


def main(seeds: tuple[int, ...] = (0, 1, 2)) -> None:
    """Print the table of effect_rms per form and seed (the module docstring's)."""
    print("| form | design | class | seed | enc | pot | load_cell_n |")
    print("| --- | --- | --- | ---: | ---: | ---: | ---: |")
    for name in BLIND_FORMS:
        for seed in seeds:
            r = effect_rms(name, seed)
            f = FORMS[name]
            print(
                f"| {name} | {f.design} | {f.expected_class} | {seed} | "
                + " | ".join(f"{r[c]:.1f}" for c in SIGNALS)
                + " |",
                flush=True,
            )


if __name__ == "__main__":
    main()
