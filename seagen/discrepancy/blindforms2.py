"""Blind set 2 of hidden-effect forms (issue 39 item 3): truth plants written apart from the term library.

Each form is a Plant subclass that adds one physical law (or distorts what a sensor reads) to the design's
default plant; its parameters are drawn per seed from the ranges in FORMS. The expected class, the acting
channel(s) and the true parameter values are committed here before any discovery run. The truth plant keeps
the design's default catalogue on (the hidden part is only the subclass's law), so the base the workflow
starts from is the design's own default config and hides nothing else. No form draws from the plant's noise
generator: with the same seed, a truth plant and the default plant see the same noise.

Channels ("force": the load cell, "position": the pot and encoder): a sensor distortion acts on its own
sensor's channel; a law of the mechanics acts on "both" when it moves the shaft where the pot sees it (before
contact) and on "force" when it only acts under load, in contact (beyond the pot's view).

Visibility (`visibility`): RMS change of the logged signals, truth plant minus the design's default plant,
same seed (0), the quick protocol `bench.measure(..., fast=True)`, over the rows both logged; load cell in N
(in its noise sigmas), pot in counts (in its noise sigmas: 10 counts on a 12-bit pot, 2.5 on micro_6v's
10-bit), encoder in counts (no noise; stiff_24v's are 61 nm, micro_6v's 0.67 um, the paper's 4.4 um). A
force-side form also moves the pot and encoder rows because the protocol retracts when the logged force
reaches its peak. rows: logged with / without the form. Printed by `python -m seagen.discrepancy.blindforms2`:

| form | design | class | channels | load cell N (sigmas) | pot counts (sigmas) | enc | rows |
| --- | --- | --- | --- | --- | --- | --- | --- |
| gear_mesh_error | paper | periodic | both | 0.238 (4.5) | 27.7 (2.8) | 28 | 1478/1482 |
| pot_gear_ripple | stiff_24v | periodic | position | 0.000 (0.0) | 27.8 (2.8) | 0 | 1594/1594 |
| battery_polarisation | micro_6v | drift | both | 0.486 (7.1) | 1.0 (0.4) | 666 | 14000/13581 |
| cell_creep | paper | drift | force | 0.593 (9.8) | 62.1 (6.2) | 98 | 1473/1482 |
| bridge_warmup | paper | drift | force | 0.700 (11.4) | 71.7 (7.2) | 110 | 1475/1482 |
| load_friction | paper | state_friction | force | 1.145 (18.7) | 72.7 (7.3) | 133 | 1547/1482 |
| dwell_stiction | paper | state_friction | both | 0.652 (11.2) | 117.1 (11.7) | 74 | 1512/1482 |
| rough_spot | stiff_24v | state_friction | both | 0.446 (8.3) | 33.8 (3.4) | 2284 | 1609/1594 |
| bouc_wen_spring | paper | hysteresis | both | 0.436 (7.1) | 36.4 (3.6) | 44 | 1464/1482 |
| cell_loop_hysteresis | stiff_24v | hysteresis | force | 1.115 (19.1) | 68.7 (6.9) | 6037 | 1528/1594 |
| coil_contact | paper | nonlinear_stiffness | force | 2.185 (34.5) | 78.3 (7.8) | 290 | 1331/1482 |
| cell_filter_2pole | stiff_24v | sensor_lag | force | 1.430 (22.7) | 73.1 (7.3) | 5384 | 1678/1594 |
| cell_adc_truncation | micro_6v | quantisation | force | 0.169 (2.5) | 0.8 (0.3) | 245 | 13695/13581 |
| amp_soft_rail | paper | saturation | force | 2.636 (41.2) | 67.4 (6.7) | 490 | 1713/1482 |
| current_limit | stiff_24v | saturation | both | 0.557 (8.7) | 51.5 (5.2) | 3535 | 1631/1594 |
| pad_relaxation | paper | other | force | 2.360 (37.4) | 57.4 (5.7) | 220 | 1358/1482 |
| pot_force_crosstalk | micro_6v | other | position | 0.000 (0.0) | 9.1 (3.6) | 0 | 13581/13581 |

Seeds 1 and 2 give the same picture: every form moves the channel it acts on by at least 2.5 sigmas RMS
(smallest: pot_gear_ripple 2.5 on the pot, gear_mesh_error 2.7 on the load cell, both seed 2).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
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
DESIGNS_DIR = Path(__file__).resolve().parents[2] / "examples" / "actuators"


def design(name: str) -> Actuator:
    """The actuator description `name`: "paper" (the default) or an example design's file stem."""
    if name == "paper":
        return default_actuator()
    return load_actuator(DESIGNS_DIR / f"{name}.toml")


def _state(plant: Plant, name: str) -> np.ndarray:
    """A per-element state of a form (zeros at first use)."""
    if not hasattr(plant, name):
        setattr(plant, name, np.zeros_like(plant.shaft_mm))
    return getattr(plant, name)


def _set_cell(s: Any, plant: Plant, load_cell: np.ndarray) -> Any:
    """A sensor sample with its load-cell reading replaced (and the shaft force derived from it)."""
    s.load_cell_n = load_cell
    s.force_n = load_cell / plant.ratio
    return s


def _set_pot(s: Any, plant: Plant, pot: np.ndarray) -> Any:
    """A sensor sample with its pot reading replaced (rounded and clipped to the ADC like the plant's)."""
    s.pot = np.clip(np.rint(pot), 0, plant.geo.adc_max).astype(np.int64)
    return s


# --- periodic in position ------------------------------------------------------------------------------


class GearMeshError(Plant):
    """Transmission error of the last (plastic) gear stage: the nut runs ahead of / behind the motor by
    a1 sin(2 pi x / P + phi1) + a2 sin(4 pi x / P + phi2), x the motor's travel at the nut, P the nut travel
    per tooth of the output gear (one mesh cycle), a2 the tooth-profile's second harmonic."""

    period_mm: float
    amplitude_mm: float
    second_amplitude_mm: float
    phase_rad: float
    phase2_rad: float

    def _lead(self) -> np.ndarray:
        """The nut's kinematic position: the motor's plus the mesh error."""
        x = 2 * np.pi * self.motor_mm / self.period_mm
        err = self.amplitude_mm * np.sin(x + self.phase_rad)
        err = err + self.second_amplitude_mm * np.sin(2 * x + self.phase2_rad)
        return super()._lead() + err


class PotGearRipple(Plant):
    """The pot turned by the linkage joint through a small spur pair: its mesh error makes the pot read the
    joint angle plus A sin(2 pi (angle - home) / P + phi), P = 360 deg / teeth of the joint gear."""

    period_deg: float
    amplitude_deg: float
    phase_rad: float

    def read(self):
        """The pot's reading of the angle with the ripple (noise and drop as the plant's own)."""
        s = super().read()
        angle = self.geo.angle_from_shaft(np.minimum(self.shaft_mm, self.y_contact))
        ripple = self.amplitude_deg * np.sin(
            2 * np.pi * (angle - self.geo.home_deg) / self.period_deg + self.phase_rad
        )
        extra = self.geo.pot_from_angle(angle + ripple) - self.geo.pot_from_angle(angle)
        return _set_pot(s, self, s.pot + extra)


# --- drifting -------------------------------------------------------------------------------------------


class BatteryPolarisation(Plant):
    """A battery-fed drive: the pack's polarisation (its RC branch) builds up with the current drawn, and the
    motor sees the command times (1 - r p), p = |current| through a first-order lag of tau (a slow sag of the
    drive gain over a trial, recovering at rest)."""

    sag_share: float  # r: supply lost per unit (stall-normalised) current, settled
    tau_s: float

    def step(self, motor_v: Any) -> None:
        """Step with the sagging command, then the polarisation state."""
        p = _state(self, "_pol")
        super().step(np.asarray(motor_v, float) * (1.0 - self.sag_share * p))
        a = min(self.cfg.dt_s / self.tau_s, 1.0)
        self._pol = p + (np.abs(self.current) - p) * a


class CellCreep(Plant):
    """A load cell on a polymer mount that creeps under load: its reading gains c times the force through
    a first-order lag of tau (the sensitivity drifts up by c over a held load, back at rest)."""

    creep_share: float
    tau_s: float

    def step(self, motor_v: Any) -> None:
        """Step, then the creep state follows the force."""
        z = _state(self, "_creep")
        super().step(motor_v)
        self._creep = z + (self.shaft_force - z) * min(self.cfg.dt_s / self.tau_s, 1.0)

    def read(self):
        """The reading plus the crept share (at the tip)."""
        s = super().read()
        return _set_cell(s, self, s.load_cell_n + self.creep_share * _state(self, "_creep") * self.ratio)


class BridgeWarmup(Plant):
    """A bridge powered at the start of each trial: its zero shifts as the gauges warm (fast, A1, tau1) and
    the body follows (slow, A2 of the opposite sign, tau2): A1 (1 - exp(-t/tau1)) + A2 (1 - exp(-t/tau2))."""

    fast_offset_n: float
    fast_tau_s: float
    slow_offset_n: float
    slow_tau_s: float

    def read(self):
        """The reading plus the warm-up zero shift (N at the tip)."""
        s = super().read()
        t = self.t
        shift = self.fast_offset_n * (1 - math.exp(-t / self.fast_tau_s))
        shift += self.slow_offset_n * (1 - math.exp(-t / self.slow_tau_s))
        return _set_cell(s, self, s.load_cell_n + shift)


# --- state-dependent friction ---------------------------------------------------------------------------


class LoadFriction(Plant):
    """Friction that grows with the load carried: the guide's normal force rises with the spring's push, so
    the band on the shaft gains mu |F| (F the force the structure carried at the last step)."""

    mu: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's friction plus the load-proportional part."""
        fwd, rev = super().friction_limits(angle_deg)
        extra = self.mu * np.abs(self._history[0])
        return fwd + extra, rev + extra


class DwellStiction(Plant):
    """Stiction that ages while the contact rests (rate-and-state friction, Dieterich's aging law): a contact
    age theta with d theta / dt = 1 - |v| theta / D_c (it grows at rest, falls to D_c / |v| in sliding), and
    extra friction b ln(1 + theta / theta_0) on the shaft. The shaft has rested `rest_s` before each trial,
    so its first breakaway carries the full aged stiction."""

    b_n: float
    d_c_mm: float
    theta0_s: float
    rest_s: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's friction plus the aged stiction."""
        fwd, rev = super().friction_limits(angle_deg)
        extra = self.b_n * fmath.log(1 + self._age() / self.theta0_s)
        return fwd + extra, rev + extra

    def _age(self) -> np.ndarray:
        """The contact age (s), from the rest before the trial at first use."""
        if not hasattr(self, "_theta"):
            self._theta = np.full_like(self.shaft_mm, self.rest_s)
        return self._theta

    def step(self, motor_v: Any) -> None:
        """Step, then age the contact (exactly integrated over the step at the step's speed)."""
        theta = self._age()
        super().step(motor_v)
        dt, rate = self.cfg.dt_s, np.abs(self.v_shaft) / self.d_c_mm
        decay = fmath.exp(-rate * dt)
        self._theta = np.where(
            rate > 0, theta * decay + (1 - decay) / np.where(rate > 0, rate, 1.0), theta + dt
        )


class RoughSpot(Plant):
    """A worn, rough stretch of the shaft's guide: extra friction A exp(-((y - y0) / w)^2), y the shaft's
    advance."""

    extra_n: float
    center_mm: float
    width_mm: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's friction plus the rough stretch's."""
        fwd, rev = super().friction_limits(angle_deg)
        q = (self.shaft_mm - self.center_mm) / self.width_mm
        extra = self.extra_n * fmath.exp(-(q * q))
        return fwd + extra, rev + extra


# --- hysteresis -----------------------------------------------------------------------------------------


class BoucWenSpring(Plant):
    """A Bouc-Wen element beside the spring (a printed spring seat that yields and slips back): force k_h z,
    dz = dd (1 - (|z| / z0) (1 + sign(dd z)) / 2), so z saturates at +-z0 when loading and unloads
    elastically (n = 1, beta = gamma = 1 / (2 z0))."""

    k_h_n_per_mm: float
    z0_mm: float

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The spring plus the hysteretic element's force (its state held within a step)."""
        return super().spring_force(d, idx) + self.k_h_n_per_mm * pick(_state(self, "_z"), idx)

    def step(self, motor_v: Any) -> None:
        """Step, then advance z with the spring's compression change."""
        z = _state(self, "_z")
        d0 = self.nut_mm - self.shaft_mm
        super().step(motor_v)
        dd = (self.nut_mm - self.shaft_mm) - d0
        self._z = z + dd * (1 - (np.abs(z) / self.z0_mm) * (1 + np.sign(dd * z)) / 2)


class CellLoopHysteresis(Plant):
    """A load cell whose reading runs on two branches: reading + w s (tip N), s a memory of the last loading
    direction, ds = |dF| / F0 (sign(dF) - s) with F the force on the shaft (a smooth major loop of height 2 w,
    turning over F0)."""

    half_height_n: float
    turn_n: float

    def step(self, motor_v: Any) -> None:
        """Step, then move the branch state with the force change."""
        s, f0 = _state(self, "_branch"), self.shaft_force.copy()
        super().step(motor_v)
        df = self.shaft_force - f0
        self._branch = s + np.abs(df) / self.turn_n * (np.sign(df) - s)

    def read(self):
        """The reading on its branch."""
        s = super().read()
        return _set_cell(s, self, s.load_cell_n + self.half_height_n * _state(self, "_branch"))


# --- nonlinear stiffness, sensor lag, quantisation, saturation --------------------------------------------


class CoilContact(Plant):
    """A spring whose end coils close in turn: beyond compression d_b it stiffens by dk (one coil fewer)."""

    extra_k_n_per_mm: float
    onset_mm: float

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The spring plus the closed coils' extra stiffness."""
        return super().spring_force(d, idx) + self.extra_k_n_per_mm * np.maximum(d - self.onset_mm, 0.0)

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The slope with the extra stiffness beyond the onset."""
        return super()._spring_slope(d, idx) + np.where(d > self.onset_mm, self.extra_k_n_per_mm, 0.0)


class CellFilter2(Plant):
    """A load-cell amplifier with a 2-pole low-pass (two equal first-order stages of tau each)."""

    tau_s: float

    def step(self, motor_v: Any) -> None:
        """Step, then the two filter stages."""
        a1, a2 = _state(self, "_f1"), _state(self, "_f2")
        super().step(motor_v)
        a = min(self.cfg.dt_s / self.tau_s, 1.0)
        self._f1 = a1 + (self.shaft_force - a1) * a
        self._f2 = a2 + (self._f1 - a2) * a

    def read(self):
        """The reading through the filter (its noise added after, as the plant's)."""
        s = super().read()
        lag = (_state(self, "_f2") - self.shaft_force) * self.ratio
        return _set_cell(s, self, s.load_cell_n + lag)


class CellAdcTruncation(Plant):
    """A load cell read by a unipolar 10-bit ADC over 0..range: code = floor(F / q), q = range / 1024,
    clipped to 0..1023 (truncation, not rounding; negative forces read 0)."""

    step_n: float

    def read(self):
        """The reading as the ADC's code times its step."""
        s = super().read()
        code = np.clip(np.floor(s.load_cell_n / self.step_n), 0, 1023)
        return _set_cell(s, self, code * self.step_n)


class AmpSoftRail(Plant):
    """A load-cell amplifier that compresses near its rail: above the knee K, the reading is
    K + S (1 - exp(-(F - K) / S)) (tip N; it tends to K + S)."""

    knee_n: float
    span_n: float

    def read(self):
        """The reading through the compressing output stage."""
        s = super().read()
        f, k, sp = s.load_cell_n, self.knee_n, self.span_n
        over = np.maximum(f - k, 0.0)
        return _set_cell(s, self, np.where(f > k, k + sp * (1 - fmath.exp(-over / sp)), f))


class CurrentLimit(Plant):
    """A drive with a current limit: the command is clipped so that |V / V_s - v / v_max| <= i_lim (the
    stall-normalised current the plant computes), i.e. the motor's force is capped at i_lim times stall."""

    limit_share: float

    def step(self, motor_v: Any) -> None:
        """Step with the command the current limit lets through."""
        vs = self.motor.supply_v
        back = self.v_motor / self.v_max
        lo, hi = vs * (back - self.limit_share), vs * (back + self.limit_share)
        super().step(np.minimum(np.maximum(np.asarray(motor_v, float), lo), hi))


# --- none of the classes cleanly ------------------------------------------------------------------------


class PadRelaxation(Plant):
    """A viscoelastic finger pad / printed linkage: a Maxwell arm (k_m with a dashpot of time constant tau)
    beside the structure, so it is stiffer under fast loading and relaxes under a held one."""

    k_m_n_per_mm: float
    tau_s: float

    def structure_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The structure plus the Maxwell arm (its dashpot's state held within a step)."""
        f, s = super().structure_force(y, idx)
        yc = pick(self.y_contact, idx)
        d = np.maximum(y - yc, 0.0)
        q = pick(_state(self, "_q"), idx)
        return f + self.k_m_n_per_mm * (d - q), s + np.where(y > yc, self.k_m_n_per_mm, 0.0)

    def step(self, motor_v: Any) -> None:
        """Step, then the dashpot creeps toward the deflection."""
        q = _state(self, "_q")
        super().step(motor_v)
        d = np.maximum(self.shaft_mm - self.y_contact, 0.0)
        self._q = q + (d - q) * min(self.cfg.dt_s / self.tau_s, 1.0)


class PotForceCrosstalk(Plant):
    """A shared ground return: the load cell's bridge current shifts the pot's reference, so the pot reads
    g counts per newton of force on the shaft higher (no lag, no current dependence)."""

    counts_per_n: float

    def read(self):
        """The pot's reading shifted by the force."""
        s = super().read()
        return _set_pot(s, self, s.pot + self.counts_per_n * self.shaft_force)


# --- the set --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Form:
    """A form: truth class, design, expected class, acting channel(s), drawn ranges, derived truth values."""

    cls: type[Plant]
    design: str
    expected_class: str
    channels: str
    ranges: dict[str, tuple[float, float]]
    derived: Callable[[dict[str, float], Actuator], dict[str, float]] | None = None


def _gear(p: dict[str, float], act: Actuator) -> dict[str, float]:
    """Second harmonic's amplitude from its share."""
    return {"second_amplitude_mm": p["amplitude_mm"] * p.pop("second_share")}


def _pot_ripple(p: dict[str, float], act: Actuator) -> dict[str, float]:
    """The ripple's amplitude in pot counts (the pot is linear in angle)."""
    g = act.pot
    return {"amplitude_counts": p["amplitude_deg"] * (2**g.adc_bits) / g.full_scale_deg}


def _bridge(p: dict[str, float], act: Actuator) -> dict[str, float]:
    """The slow offset's value from its (opposite-sign) share of the fast one."""
    return {"slow_offset_n": -p["fast_offset_n"] * p.pop("slow_share")}


def _adc(p: dict[str, float], act: Actuator) -> dict[str, float]:
    """The ADC step from its range."""
    return {"step_n": p["range_n"] / 1024.0}


def _rail(p: dict[str, float], act: Actuator) -> dict[str, float]:
    """The rail's asymptote."""
    return {"asymptote_n": p["knee_n"] + p["span_n"]}


def _crosstalk(p: dict[str, float], act: Actuator) -> dict[str, float]:
    """Counts per newton from the share of the pot's full scale per newton."""
    return {"counts_per_n": p.pop("share_per_n") * 2**act.pot.adc_bits}


TWO_PI = 2 * math.pi
FORMS: dict[str, Form] = {
    "gear_mesh_error": Form(
        GearMeshError,
        "paper",
        "periodic",
        "both",
        {
            "period_mm": (0.4, 0.8),
            "amplitude_mm": (0.04, 0.07),
            "second_share": (0.3, 0.5),
            "phase_rad": (0.0, TWO_PI),
            "phase2_rad": (0.0, TWO_PI),
        },
        _gear,
    ),
    "pot_gear_ripple": Form(
        PotGearRipple,
        "stiff_24v",
        "periodic",
        "position",
        {"period_deg": (7.0, 12.0), "amplitude_deg": (0.35, 0.6), "phase_rad": (0.0, TWO_PI)},
        _pot_ripple,
    ),
    "battery_polarisation": Form(
        BatteryPolarisation, "micro_6v", "drift", "both", {"sag_share": (0.15, 0.3), "tau_s": (2.0, 5.0)}
    ),
    "cell_creep": Form(
        CellCreep, "paper", "drift", "force", {"creep_share": (0.05, 0.1), "tau_s": (0.6, 1.5)}
    ),
    "bridge_warmup": Form(
        BridgeWarmup,
        "paper",
        "drift",
        "force",
        {
            "fast_offset_n": (0.4, 0.8),
            "fast_tau_s": (0.2, 0.5),
            "slow_share": (0.3, 0.6),
            "slow_tau_s": (2.0, 4.0),
        },
        _bridge,
    ),
    "load_friction": Form(LoadFriction, "paper", "state_friction", "force", {"mu": (0.06, 0.14)}),
    "dwell_stiction": Form(
        DwellStiction,
        "paper",
        "state_friction",
        "both",
        {"b_n": (0.3, 0.6), "d_c_mm": (0.005, 0.02), "theta0_s": (0.005, 0.02), "rest_s": (3.0, 10.0)},
    ),
    "rough_spot": Form(
        RoughSpot,
        "stiff_24v",
        "state_friction",
        "both",
        {"extra_n": (1.2, 2.5), "center_mm": (1.0, 3.0), "width_mm": (0.3, 0.7)},
    ),
    "bouc_wen_spring": Form(
        BoucWenSpring,
        "paper",
        "hysteresis",
        "both",
        {"k_h_n_per_mm": (2.0, 4.0), "z0_mm": (0.12, 0.25)},
    ),
    "cell_loop_hysteresis": Form(
        CellLoopHysteresis,
        "stiff_24v",
        "hysteresis",
        "force",
        {"half_height_n": (0.25, 0.5), "turn_n": (1.0, 3.0)},
    ),
    "coil_contact": Form(
        CoilContact,
        "paper",
        "nonlinear_stiffness",
        "force",
        {"extra_k_n_per_mm": (0.8, 1.6), "onset_mm": (1.5, 3.0)},
    ),
    "cell_filter_2pole": Form(CellFilter2, "stiff_24v", "sensor_lag", "force", {"tau_s": (0.008, 0.02)}),
    "cell_adc_truncation": Form(
        CellAdcTruncation, "micro_6v", "quantisation", "force", {"range_n": (150.0, 300.0)}, _adc
    ),
    "amp_soft_rail": Form(
        AmpSoftRail, "paper", "saturation", "force", {"knee_n": (5.0, 7.0), "span_n": (8.0, 11.0)}, _rail
    ),
    "current_limit": Form(CurrentLimit, "stiff_24v", "saturation", "both", {"limit_share": (0.11, 0.15)}),
    "pad_relaxation": Form(
        PadRelaxation, "paper", "other", "force", {"k_m_n_per_mm": (8.0, 20.0), "tau_s": (0.1, 0.4)}
    ),
    "pot_force_crosstalk": Form(
        PotForceCrosstalk, "micro_6v", "other", "position", {"share_per_n": (0.0008, 0.0015)}, _crosstalk
    ),
}
BLIND_FORMS: tuple[str, ...] = tuple(FORMS)


def draw(name: str, seed: int) -> dict[str, float]:
    """The form's physical parameters for a seed (uniform in its ranges, then the derived ones)."""
    form = FORMS[name]
    rng = np.random.default_rng([seed, BLIND_FORMS.index(name), 392])
    p = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in form.ranges.items()}
    if form.derived is not None:
        p.update(form.derived(p, design(form.design)))
    return p


def blind_case(name: str, seed: int) -> tuple[type[Plant], PlantConfig, PlantConfig, dict]:
    """(truth plant class, truth config, base config (the design's own), {expected_class, channels, truth,
    design}) of form `name` drawn for `seed`."""
    form = FORMS[name]
    p = draw(name, seed)
    attrs = {k: v for k, v in p.items() if k in form.cls.__annotations__}
    cls = type(f"{form.cls.__name__}_{seed}", (form.cls,), attrs)
    base = PlantConfig(actuator=design(form.design))
    truth = dataclasses.replace(base, effects=dataclasses.replace(base.effects))
    info = {
        "expected_class": form.expected_class,
        "channels": form.channels,
        "truth": p,
        "design": form.design,
    }
    return cls, truth, base, info


def visibility(name: str, seed: int = 0) -> dict[str, float]:
    """RMS change of the logged signals a form makes (truth plant minus the design's default plant, same
    seed, the quick protocol `bench.measure(..., fast=True)`, over the rows both logged): load cell in N and
    in its noise sigma, pot in counts and in its noise sigma, encoder in counts."""
    from seagen.discrepancy.bench import measure

    cls, truth, base, _ = blind_case(name, seed)
    with_form = measure(truth, seed=seed, fast=True, plant_cls=cls)
    without = measure(base, seed=seed, fast=True)
    n = min(with_form.mask.shape[1], without.mask.shape[1])
    both = with_form.mask[:, :n] & without.mask[:, :n]
    geo_split = base.actuator.linkage.split_deg
    lc = base.load_cells
    sigma_cell = np.where(without.angle <= geo_split, lc.horizontal_sigma_n, lc.vertical_sigma_n)[:, None]
    sigma_pot = base.effects.pot_noise.sigma_counts

    def rms(channel: str, scale: Any = 1.0) -> float:
        diff = (with_form.meas[channel][:, :n] - without.meas[channel][:, :n]) / scale
        return float(np.sqrt(np.mean(diff[both] ** 2)))

    return {
        "load_cell_n": rms("load_cell_n"),
        "load_cell_sigmas": rms("load_cell_n", sigma_cell),
        "pot_counts": rms("pot"),
        "pot_sigmas": rms("pot", sigma_pot),
        "enc_counts": rms("enc"),
        "rows_with": float(with_form.mask.sum()),
        "rows_without": float(without.mask.sum()),
    }


def main() -> None:
    """Print the visibility table of every form (seed 0), as in the module docstring."""
    head = (
        "form",
        "design",
        "class",
        "channels",
        "load cell N (sigmas)",
        "pot counts (sigmas)",
        "enc",
        "rows",
    )
    print("| " + " | ".join(head) + " |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in BLIND_FORMS:
        f, v = FORMS[name], visibility(name)
        print(
            f"| {name} | {f.design} | {f.expected_class} | {f.channels} | {v['load_cell_n']:.3f} "
            f"({v['load_cell_sigmas']:.1f}) | {v['pot_counts']:.1f} ({v['pot_sigmas']:.1f}) | "
            f"{v['enc_counts']:.0f} | {v['rows_with']:.0f}/{v['rows_without']:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
