"""Plant parameters: one dataclass per component and per named effect, loadable from and savable to TOML."""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field, fields
from typing import Any

import tomli_w

from seagen.actuator import Actuator, default_actuator
from seagen.atomic import write_text
from seagen.errors import UserError
from seagen.fields import read_toml


class ConfigError(UserError):
    """A plant config file that cannot be used (names the file and the key)."""


@dataclass(frozen=True)
class Motor:
    """The drive seen at the nut (back-drivable lead screw), read from the actuator description's [motor].

    Every number is the actuator's, stall force and time constant included: they come from the motor's
    datasheet and the gearbox and screw, not from what is non-ideal about one build (plant.toml)."""

    supply_v: float
    no_load_rpm: float
    counts_per_rev: int
    mm_per_count: float
    time_constant_s: float
    stall_force_n: float

    @classmethod
    def of(cls, act: Actuator) -> Motor:
        """The motor of an actuator description."""
        m = act.motor
        return cls(
            supply_v=m.supply_v,
            no_load_rpm=m.no_load_rpm,
            counts_per_rev=m.counts_per_rev,
            mm_per_count=act.mm_per_count,
            time_constant_s=m.time_constant_s,
            stall_force_n=m.stall_force_n,
        )

    @property
    def v_max_mm_s(self) -> float:
        """No-load speed seen at the nut (mm/s): motor counts per second times the nut travel per count."""
        return self.no_load_rpm / 60.0 * self.counts_per_rev * self.mm_per_count

    def current(self, volts: Any, v_mm_s: Any) -> Any:
        """Motor current normalised to stall at the supply voltage, from the command and the nut speed: the
        one estimate the plant steps with and the discrepancy analysis reads."""
        return volts / self.supply_v - v_mm_s / self.v_max_mm_s


@dataclass
class LoadCells:
    """Horizontal mount up to the description's split angle, vertical above; each with its own noise (N at
    the tip)."""

    horizontal_sigma_n: float = 0.05
    vertical_sigma_n: float = 0.08


@dataclass
class Effect:
    """Base of the named non-ideal effects: each can be switched on and off."""

    enabled: bool = False


@dataclass
class ActuatorFriction(Effect):
    """Coulomb friction on the output shaft (F = F_c sign v, stick below); lower when retracting."""

    enabled: bool = True
    force_n: float = 2.7  # paper Fig. 7: 2.7 N (0.68 mm of compression)
    reverse_ratio: float = 0.55  # chosen: friction when the shaft retracts, as a fraction of force_n


@dataclass
class LinkageFriction(Effect):
    """Friction added (or relieved) by the linkage, at the shaft: c0 + c1 x + c2 x^2, with x the contact
    angle above the description's split, over the range above it: (angle - split) / (max - split)."""

    enabled: bool = True
    # chosen so that the combined friction measured the paper's way is ~2.1, 2.4, 4.45 N (Fig. 8)
    c0_n: float = -0.20
    c1_n: float = 1.343
    c2_n: float = 1.34


@dataclass
class ViscousFriction(Effect):
    """Speed-proportional drag on the output shaft: F = b v."""

    b_n_s_per_mm: float = 0.15


@dataclass
class StribeckFriction(Effect):
    """Extra break-away friction at low speed: (F_s - F_c) exp(-(v/v_s)^2)."""

    extra_static_n: float = 1.5
    v_s_mm_s: float = 0.5


@dataclass
class SeriesCompliance(Effect):
    """Housing, shaft and linkage deformation in series with the spring: d = F/k + beta F^2."""

    enabled: bool = True
    k_n_per_mm: float = 30.0  # chosen: with beta, the naive error grows from ~20 % at 5 N to ~40 % at 15 N
    beta_mm_per_n2: float = 0.0048


@dataclass
class Backlash(Effect):
    """Dead band between motor (encoder) and nut on reversal: gap of width 2 b."""

    half_width_mm: float = 0.06


@dataclass
class SpringPreload(Effect):
    """Spring force offset: F = k d + F_0."""

    force_n: float = 1.0


@dataclass
class SpringNonlinearity(Effect):
    """Progressive spring: F = k d + k3 d^3."""

    k3_n_per_mm3: float = 0.06


def pot_full_scale(act: Actuator) -> float:
    """Counts of the pot ADC's full scale (2^adc_bits) of an actuator description."""
    return float(act.adc_max + 1)


# Effect parameters in pot ADC counts, with their defaults as shares of the pot's full scale: a default
# plant of any design has the same pot non-idealities relative to its range (on the paper's 12-bit pot: 120
# counts per unit current, sigma 10 counts; both shares are exact binary fractions, so the products are
# exactly those numbers there). A value given in plant.toml is in counts of that actuator's ADC.
POT_SHARES: dict[tuple[str, str], float] = {
    ("pot_voltage_drop", "counts_per_unit_current"): 0.029296875,
    ("pot_noise", "sigma_counts"): 0.00244140625,
}
PAPER_POT_FULL_SCALE = pot_full_scale(default_actuator())


def counts_range(
    effect: str, param: str, span: tuple[float, float], full_scale: float, act: Actuator | None = None
) -> tuple[float, float]:
    """A parameter's (low, high) range in its units: given as shares of the pot's full scale (`full_scale`
    counts) for a parameter in pot counts (POT_SHARES' keys), as the paper's value times design_factor on
    `act` for one at a design's scale (DESIGN_UNITS; as is when `act` is None), as is for any other (boxes,
    plausible and drawn ranges)."""
    if (effect, param) in POT_SHARES:
        k = full_scale
    else:
        k = 1.0 if act is None else design_factor(effect, param, act)
    return span[0] * k, span[1] * k


# Effect parameters at the scale of a design's force and travel, as the (force, travel) exponents of their
# unit: N (1, 0), mm (0, 1), N/mm (1, -1), mm/N^2 (-2, 1), N/mm^3 (1, -3), N s/mm (1, -1). The discrepancy
# search's boxes of them are the paper's times design_factor (a design far from the paper's is searched
# around its own scale); of the plant's defaults, the structure's (series_compliance: a share of the
# spring's deflection like the paper's) and those of the effects off by default. The actuator friction is
# the description's transmission.friction_n (Effects.of); the other frictions and offsets the plant has on by
# default stay absolute. Exactly 1.0 on the paper's actuator: its numbers are unchanged.
DESIGN_UNITS: dict[tuple[str, str], tuple[int, int]] = {
    ("actuator_friction", "force_n"): (1, 0),
    ("linkage_friction", "c0_n"): (1, 0),
    ("linkage_friction", "c1_n"): (1, 0),
    ("linkage_friction", "c2_n"): (1, 0),
    ("viscous_friction", "b_n_s_per_mm"): (1, -1),
    ("stribeck_friction", "extra_static_n"): (1, 0),
    ("stribeck_friction", "v_s_mm_s"): (0, 1),
    ("series_compliance", "k_n_per_mm"): (1, -1),
    ("series_compliance", "beta_mm_per_n2"): (-2, 1),
    ("backlash", "half_width_mm"): (0, 1),
    ("spring_preload", "force_n"): (1, 0),
    ("spring_nonlinearity", "k3_n_per_mm3"): (1, -3),
    ("load_cell_offset", "offset_n"): (1, 0),
}
PLANT_SCALED = (  # defaults scaled with the design (see above)
    "series_compliance",
    "viscous_friction",
    "stribeck_friction",
    "backlash",
    "spring_preload",
    "spring_nonlinearity",
    "load_cell_offset",
)


def design_factor(effect: str, param: str, act: Actuator) -> float:
    """Factor on the paper's value of a DESIGN_UNITS parameter for `act`: its force range over the paper's
    (force) and its spring's compression at that range over the paper's (travel), each to its exponent;
    1.0 for any other parameter and exactly 1.0 on the paper's actuator."""
    if (effect, param) not in DESIGN_UNITS:
        return 1.0
    a, b = DESIGN_UNITS[(effect, param)]
    paper = default_actuator()
    f_paper, f = paper.control.force_max_n, act.control.force_max_n
    force = f / f_paper
    travel = (f / act.stiffness_n_per_mm) / (f_paper / paper.stiffness_n_per_mm)
    return float(force**a * travel**b)


@dataclass
class PotVoltageDrop(Effect):
    """Pot reads high while the motor draws current (|i| normalised to stall at the supply), decays after.

    counts_per_unit_current is in pot counts (its default: POT_SHARES of the described pot's full scale)."""

    enabled: bool = True
    counts_per_unit_current: float = (
        POT_SHARES[("pot_voltage_drop", "counts_per_unit_current")] * PAPER_POT_FULL_SCALE
    )
    time_constant_s: float = 0.12


@dataclass
class PotNoise(Effect):
    """Reference-voltage fluctuation: zero-mean Gaussian noise on the pot counts (default: POT_SHARES of the
    described pot's full scale)."""

    enabled: bool = True
    sigma_counts: float = POT_SHARES[("pot_noise", "sigma_counts")] * PAPER_POT_FULL_SCALE


@dataclass
class LoadCellOffset(Effect):
    """Zero offset of the load cell (N at the tip)."""

    offset_n: float = 0.5


@dataclass
class TransportDelay(Effect):
    """Latency between actuation and measured force: F_meas(t) = F(t - tau)."""

    delay_s: float = 0.03


LEARNED_INPUTS = ("force_n", "speed_mm_s", "current", "contact_deg")  # plant signals a learned residual reads
LEARNED_CHANNELS = ("load_cell_n", "pot")  # measured channels it may correct
LEARNED_TERMS = 5  # basis functions per input (see sim.learned_basis)


@dataclass
class LearnedResidual(Effect):
    """A fitted smooth correction added to one measured channel (not physics: what the catalogue lacks).

    Written by `seagen discrepancy` when no catalogue effect explains a region: value = coef[0] +
    sum over inputs of coef . basis(input / scale), see sim.learned_basis. Off by default."""

    channel: str = "load_cell_n"
    inputs: list[str] = field(default_factory=list)
    scales: list[float] = field(default_factory=list)
    coef: list[float] = field(default_factory=list)

    def problem(self) -> str | None:
        """Why this correction cannot be evaluated, or None."""
        if self.channel not in LEARNED_CHANNELS:
            return f"channel must be one of {', '.join(LEARNED_CHANNELS)}, got {self.channel!r}"
        bad = [i for i in self.inputs if i not in LEARNED_INPUTS]
        if bad:
            return f"unknown input {bad[0]!r} (known: {', '.join(LEARNED_INPUTS)})"
        if len(self.scales) != len(self.inputs) or any(s <= 0 for s in self.scales):
            return "scales must hold one positive number per input"
        if len(self.coef) != 1 + LEARNED_TERMS * len(self.inputs):
            return f"coef must hold 1 + {LEARNED_TERMS} x len(inputs) numbers"
        return None


# --- The term library (discrepancy/terms.py): forms the catalogue lacks, each a plant effect (off by default)
# that a discrepancy run adds only when the catalogue runs out; never a catalogue name (CATALOGUE).


@dataclass
class LeadError(Effect):
    """Lead-screw error: the nut is ahead of the motor by a cos(2 pi x / P + phi), x the motor's travel."""

    amplitude_mm: float = 0.02
    period_mm: float = 1.0
    phase_rad: float = 0.0


@dataclass
class Cogging(Effect):
    """Cogging: a force A cos(2 pi x / P + phi) on the motor (at the nut), x the motor's travel."""

    force_n: float = 1.0
    period_mm: float = 0.5
    phase_rad: float = 0.0


@dataclass
class SpringDrift(Effect):
    """A spring whose stiffness drifts during a trial: k (1 + share (1 - exp(-t / tau))) for compression."""

    share: float = 0.1
    time_constant_s: float = 2.0


@dataclass
class CellDrift(Effect):
    """A load-cell zero drifting during a trial: offset A (1 - exp(-t / tau)), N at the tip."""

    offset_n: float = 0.5
    time_constant_s: float = 2.0


@dataclass
class RateFriction(Effect):
    """Friction with a speed state: extra (exp(-w / v_c)) on the shaft, w = |v| through a first-order lag."""

    extra_n: float = 1.0
    v_c_mm_s: float = 1.0
    time_constant_s: float = 0.02


@dataclass
class BristleFriction(Effect):
    """Presliding friction: a band F (1 - exp(-s / x0)) with s the shaft's travel since its last reversal."""

    force_n: float = 1.0
    x0_mm: float = 0.05


@dataclass
class SpringHysteresis(Effect):
    """An elastoplastic (Prandtl) element beside the spring: k_h (d - h), h following d in a play of +-w."""

    k_n_per_mm: float = 1.0
    half_width_mm: float = 0.2


@dataclass
class SpringPoly(Effect):
    """A polynomial spring: F = k d + k2 d^2 + k3 d^3 (either sign) for compression d >= 0."""

    k2_n_per_mm2: float = 0.1
    k3_n_per_mm3: float = 0.0


@dataclass
class CellLag(Effect):
    """A load cell behind a first-order lag of time constant tau."""

    time_constant_s: float = 0.02


@dataclass
class CellQuantisation(Effect):
    """A load cell read in steps of q newtons (after its noise)."""

    step_n: float = 0.2


@dataclass
class CellSaturation(Effect):
    """A load cell that saturates at +-limit newtons."""

    limit_n: float = 10.0


@dataclass
class DriveSaturation(Effect):
    """A drive that saturates: the motor's command clipped at +-limit volts (below the supply)."""

    limit_v: float = 8.0


@dataclass
class PotLag(Effect):
    """A pot behind a first-order lag of time constant tau (its angle reading, from the first reading on)."""

    time_constant_s: float = 0.02


@dataclass
class PotHysteresis(Effect):
    """A pot reading through a play of +-w counts (from its first reading): h = clip(h, pot - w, pot + w)."""

    half_width_counts: float = 8.0


@dataclass
class PotQuantisation(Effect):
    """A pot read in steps of q counts (a coarser converter, after its noise)."""

    step_counts: float = 16.0


@dataclass
class PotDrift(Effect):
    """A pot zero drifting during a trial: offset A (1 - exp(-t / tau)) counts, t the time into the trial."""

    offset_counts: float = 20.0
    time_constant_s: float = 2.0


@dataclass
class PotSaturation(Effect):
    """A pot reading that clamps above: min(pot, limit) counts (its divider or converter saturates)."""

    limit_counts: float = 3000.0


@dataclass
class PotReadingLag(Effect):
    """The pot's whole reading (angle and voltage drop) behind a first-order lag per logged sample:
    c += (pot - c) (1 - exp(-dt / tau)), dt the time since the last reading (an RC filter on its line)."""

    time_constant_s: float = 0.02


@dataclass
class CellSoftSaturation(Effect):
    """A load cell that saturates with a knee: F / (1 + |F / L|^n)^(1 / n) (n the knee's sharpness; a
    large n is the hard clip at +-L)."""

    limit_n: float = 10.0
    sharpness: float = 4.0


@dataclass
class CellHysteresis(Effect):
    """A hysteretic load cell (Bouc-Wen type): reading += h z, z in [-1, 1] driven by the tip force's change
    dF per reading: dz = (dF / w) (1 - sign(dF) sign(z) |z|^n) (n = 1 an exponential approach, a large n
    a play of width 2 w)."""

    force_n: float = 0.5
    width_n: float = 2.0
    shape: float = 1.0


@dataclass
class BreakawayFriction(Effect):
    """Break-away friction with a speed state and a shape: extra / (1 + (w / v_s)^delta) on the shaft, w =
    |v| through a first-order lag of time constant tau (delta = 2: the Lorentzian, Hess-Soom form)."""

    extra_n: float = 1.0
    v_s_mm_s: float = 1.0
    time_constant_s: float = 0.02
    shape: float = 2.0


@dataclass
class SpringBoucWen(Effect):
    """Hysteresis in the spring (Bouc-Wen type): F += h z while compressed, z in [-1, 1] driven by the
    compression's change dd per step: dz = (dd / w) (1 - sign(dd) sign(z) |z|^n) (n = 1 an exponential
    approach, a large n a play of width 2 w)."""

    force_n: float = 1.0
    width_mm: float = 0.2
    shape: float = 1.0


@dataclass
class LoadFriction(Effect):
    """Friction that grows with the load carried (Coulomb's mu N): the band on the shaft gains mu |F|, F the
    force the structure carried at the last step."""

    mu: float = 0.05


@dataclass
class PositionFriction(Effect):
    """Friction varying along the shaft's travel: a stretch of extra friction A exp(-|(y - c) / w|^n), y the
    shaft's advance (n = 2 a Gaussian bump, a large n a flat-topped rough stretch of half-width w)."""

    extra_n: float = 1.0
    center_mm: float = 2.0
    width_mm: float = 0.5
    shape: float = 2.0


@dataclass
class SpringKnee(Effect):
    """A stiffness that steps at a compression: F += dk max(d - d0, 0) (coils closing, a second spring or
    a stop engaging: dk > 0; a buckling element letting go: dk < 0)."""

    dk_n_per_mm: float = 1.0
    onset_mm: float = 2.0


@dataclass
class DriveGainDrift(Effect):
    """A drive whose gain drifts during a trial: the motor sees V (1 + share (1 - exp(-t / tau))) (a
    battery's sag, a warming amplifier), t the time into the trial."""

    share: float = -0.1
    time_constant_s: float = 2.0


@dataclass
class CurrentLimit(Effect):
    """A drive with a current limit: the command clipped so that the stall-normalised current |V / V_s -
    v / v_max| stays within the limit (the motor's force capped at that share of stall)."""

    limit_share: float = 0.3


@dataclass
class CellGainDrift(Effect):
    """A load cell whose sensitivity drifts during a trial: reading x (1 + share (1 - exp(-t / tau))), t the
    time into the trial (a bridge's gain settling, a mount's creep)."""

    share: float = 0.05
    time_constant_s: float = 2.0


@dataclass
class PotRipple(Effect):
    """A pot reading with a ripple periodic in its own angle: pot += A cos(2 pi c / P + phi), c the pot's
    angle reading in counts (a gear pair driving the pot, a wiper track's waviness)."""

    amplitude_counts: float = 10.0
    period_counts: float = 100.0
    phase_rad: float = 0.0


@dataclass
class Effects:
    """The catalogue of DESIGN.md §3 (EFFECT_NAMES: exactly these names), then the term library (TERMS)."""

    actuator_friction: ActuatorFriction = field(default_factory=ActuatorFriction)
    linkage_friction: LinkageFriction = field(default_factory=LinkageFriction)
    viscous_friction: ViscousFriction = field(default_factory=ViscousFriction)
    stribeck_friction: StribeckFriction = field(default_factory=StribeckFriction)
    series_compliance: SeriesCompliance = field(default_factory=SeriesCompliance)
    backlash: Backlash = field(default_factory=Backlash)
    spring_preload: SpringPreload = field(default_factory=SpringPreload)
    spring_nonlinearity: SpringNonlinearity = field(default_factory=SpringNonlinearity)
    pot_voltage_drop: PotVoltageDrop = field(default_factory=PotVoltageDrop)
    pot_noise: PotNoise = field(default_factory=PotNoise)
    load_cell_offset: LoadCellOffset = field(default_factory=LoadCellOffset)
    transport_delay: TransportDelay = field(default_factory=TransportDelay)
    learned_residual: LearnedResidual = field(default_factory=LearnedResidual)
    lead_error: LeadError = field(default_factory=LeadError)
    cogging: Cogging = field(default_factory=Cogging)
    spring_drift: SpringDrift = field(default_factory=SpringDrift)
    cell_drift: CellDrift = field(default_factory=CellDrift)
    rate_friction: RateFriction = field(default_factory=RateFriction)
    bristle_friction: BristleFriction = field(default_factory=BristleFriction)
    spring_hysteresis: SpringHysteresis = field(default_factory=SpringHysteresis)
    spring_poly: SpringPoly = field(default_factory=SpringPoly)
    cell_lag: CellLag = field(default_factory=CellLag)
    cell_quantisation: CellQuantisation = field(default_factory=CellQuantisation)
    cell_saturation: CellSaturation = field(default_factory=CellSaturation)
    drive_saturation: DriveSaturation = field(default_factory=DriveSaturation)
    pot_lag: PotLag = field(default_factory=PotLag)
    pot_hysteresis: PotHysteresis = field(default_factory=PotHysteresis)
    pot_quantisation: PotQuantisation = field(default_factory=PotQuantisation)
    pot_drift: PotDrift = field(default_factory=PotDrift)
    pot_saturation: PotSaturation = field(default_factory=PotSaturation)
    pot_reading_lag: PotReadingLag = field(default_factory=PotReadingLag)
    cell_soft_saturation: CellSoftSaturation = field(default_factory=CellSoftSaturation)
    cell_hysteresis: CellHysteresis = field(default_factory=CellHysteresis)
    breakaway_friction: BreakawayFriction = field(default_factory=BreakawayFriction)
    spring_bouc_wen: SpringBoucWen = field(default_factory=SpringBoucWen)
    load_friction: LoadFriction = field(default_factory=LoadFriction)
    position_friction: PositionFriction = field(default_factory=PositionFriction)
    spring_knee: SpringKnee = field(default_factory=SpringKnee)
    drive_gain_drift: DriveGainDrift = field(default_factory=DriveGainDrift)
    current_limit: CurrentLimit = field(default_factory=CurrentLimit)
    cell_gain_drift: CellGainDrift = field(default_factory=CellGainDrift)
    pot_ripple: PotRipple = field(default_factory=PotRipple)

    @classmethod
    def of(cls, act: Actuator) -> Effects:
        """The default catalogue for an actuator: its pot effects at their shares of its pot's full scale, the
        structure's and the effects off by default at its scale (DESIGN_UNITS, PLANT_SCALED)."""
        out, fs = cls(), pot_full_scale(act)
        # the actuator friction is the description's (transmission.friction_n; 2.7 N on the paper's)
        out.actuator_friction = dataclasses.replace(out.actuator_friction, force_n=act.friction_n)
        for (name, param), share in POT_SHARES.items():
            setattr(out, name, dataclasses.replace(getattr(out, name), **{param: share * fs}))
        for name, param in DESIGN_UNITS:
            if name in PLANT_SCALED:
                k = design_factor(name, param, act)
                if k != 1.0:
                    value = getattr(getattr(out, name), param) * k
                    setattr(out, name, dataclasses.replace(getattr(out, name), **{param: value}))
        return out


_UNRESOLVED = Effects()  # PlantConfig's marker for "the default catalogue of its actuator" (never kept)


# The term library's effects (discrepancy/terms.py): plant effects, but not catalogue names.
TERMS: tuple[str, ...] = (
    "lead_error",
    "cogging",
    "spring_drift",
    "cell_drift",
    "rate_friction",
    "bristle_friction",
    "spring_hysteresis",
    "spring_poly",
    "cell_lag",
    "cell_quantisation",
    "cell_saturation",
    "drive_saturation",
    "pot_lag",
    "pot_hysteresis",
    "pot_quantisation",
    "pot_drift",
    "pot_saturation",
    "pot_reading_lag",
    "cell_soft_saturation",
    "cell_hysteresis",
    "breakaway_friction",
    "spring_bouc_wen",
    "load_friction",
    "position_friction",
    "spring_knee",
    "drive_gain_drift",
    "current_limit",
    "cell_gain_drift",
    "pot_ripple",
)
ALL_EFFECTS: tuple[str, ...] = tuple(f.name for f in fields(Effects))
EFFECT_NAMES: tuple[str, ...] = tuple(e for e in ALL_EFFECTS if e not in TERMS)
# The physical catalogue a discrepancy search names from (pot_noise is a noise model, learned_residual a fit).
CATALOGUE: tuple[str, ...] = tuple(e for e in EFFECT_NAMES if e not in ("pot_noise", "learned_residual"))


@dataclass
class PlantConfig:
    """Everything the simulated SEA needs: the actuator description (its geometry and motor; not part of
    plant.toml, which says what is non-ideal about it) and the effect catalogue. The defaults reproduce
    the paper's actuator; without `effects`, the catalogue's defaults for `actuator` (Effects.of)."""

    actuator: Actuator = field(default_factory=default_actuator)
    load_cells: LoadCells = field(default_factory=LoadCells)
    effects: Effects = field(default_factory=lambda: _UNRESOLVED)
    dt_s: float = 0.001  # internal step (1 kHz)

    def __post_init__(self) -> None:
        """Resolve the default catalogue for the actuator (its pot effects scale with its pot)."""
        if self.effects is _UNRESOLVED:
            self.effects = Effects.of(self.actuator)

    @property
    def motor(self) -> Motor:
        """The motor of the actuator description."""
        return Motor.of(self.actuator)

    def with_actuator(self, act: Actuator) -> PlantConfig:
        """A copy simulating another actuator description (the same effects, pot counts unchanged)."""
        return dataclasses.replace(self, actuator=act)

    def effect(self, name: str) -> Effect:
        """The effect called `name` (one of EFFECT_NAMES or TERMS)."""
        if name not in ALL_EFFECTS:
            raise KeyError(f"unknown effect {name!r}; known: {', '.join(ALL_EFFECTS)}")
        return getattr(self.effects, name)

    def on(self, name: str) -> bool:
        """Whether the effect called `name` is enabled."""
        return self.effect(name).enabled

    def with_effect(self, name: str, enabled: bool = True, **params: Any) -> PlantConfig:
        """A copy with one effect switched and its parameters replaced."""
        new = dataclasses.replace(self, effects=dataclasses.replace(self.effects))
        eff = dataclasses.replace(self.effect(name), enabled=enabled, **params)
        setattr(new.effects, name, eff)
        return new

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict (TOML-ready): what plant.toml holds, without the actuator description (a term of
        the library only when it is on: plant.toml lists the catalogue and what a discovery added)."""
        out = {f.name: dataclasses.asdict(self)[f.name] for f in fields(self) if f.name != "actuator"}
        out["effects"] = {e: v for e, v in out["effects"].items() if e not in TERMS or v["enabled"]}
        return out


# plant.toml before the actuator description: [motor] keys -> the description's [motor] keys
MOVED_MOTOR_KEYS = ("supply_v", "no_load_rpm", "counts_per_rev", "time_constant_s", "stall_force_n")


def _fill(base: Any, data: dict[str, Any], where: str, path: str) -> Any:
    """Dataclass instance `base` with the values of `data`, rejecting unknown keys and wrong types with their
    location (keys not given keep base's values: the defaults for the actuator)."""
    known = {f.name: f for f in fields(base) if f.name != "actuator"}  # the description is its own file
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key not in known:
            raise ConfigError(f"{where}: unknown key '{path}{key}' (known: {', '.join(known)})")
        default = getattr(base, key)
        if dataclasses.is_dataclass(default):
            if not isinstance(value, dict):
                raise ConfigError(f"{where}: '{path}{key}' must be a table")
            kwargs[key] = _fill(default, value, where, f"{path}{key}.")
        elif isinstance(default, str):
            if not isinstance(value, str):
                raise ConfigError(f"{where}: '{path}{key}' must be a string, got {value!r}")
            kwargs[key] = value
        elif isinstance(default, list):
            kwargs[key] = _list(value, "str" in str(known[key].type), where, f"{path}{key}")
        elif isinstance(default, bool):
            if not isinstance(value, bool):
                raise ConfigError(f"{where}: '{path}{key}' must be true or false, got {value!r}")
            kwargs[key] = value
        else:
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ConfigError(f"{where}: '{path}{key}' must be a number, got {value!r}")
            kwargs[key] = type(default)(value)
    obj = dataclasses.replace(base, **kwargs)
    problem = obj.problem() if hasattr(obj, "problem") and obj.enabled else None
    if problem:
        raise ConfigError(f"{where}: '{path.rstrip('.')}': {problem}")
    return obj


def _list(value: Any, strings: bool, where: str, key: str) -> list:
    """A TOML array of strings or of numbers."""
    ok = isinstance(value, list) and all(
        isinstance(v, str) if strings else isinstance(v, int | float) and not isinstance(v, bool)
        for v in value
    )
    if not ok:
        raise ConfigError(f"{where}: '{key}' must be an array of {'strings' if strings else 'numbers'}")
    return [v if strings else float(v) for v in value]


def config_from_dict(
    data: dict[str, Any], where: str = "<dict>", actuator: Actuator | None = None
) -> PlantConfig:
    """PlantConfig of `actuator` (the paper's when None) from a nested dict; missing keys take their
    defaults for that actuator (pot counts: shares of its pot's full scale). A [motor] table (plant.toml
    before the actuator description) is refused with how to move it."""
    if "motor" in data:
        moved = ", ".join(f"motor.{k}" for k in MOVED_MOTOR_KEYS)
        raise ConfigError(
            f"{where}: [motor] moved to the actuator description (--actuator FILE, see "
            f"seagen/actuators/paper.toml): put {moved} under the same names in its [motor] table "
            f"and delete [motor] here"
        )
    if "actuator" in data:
        raise ConfigError(f"{where}: unknown key 'actuator' (the description is its own file: --actuator)")
    return _fill(PlantConfig(actuator=actuator or default_actuator()), data, where, "")


def load_config(path: str | os.PathLike[str], actuator: Actuator | None = None) -> PlantConfig:
    """Read a plant config from TOML for `actuator` (the paper's when None); errors name the file and key."""
    return config_from_dict(read_toml(path, ConfigError), str(path), actuator)


def save_config(cfg: PlantConfig, path: str | os.PathLike[str]) -> None:
    """Write a plant config as TOML atomically (temporary name, then rename)."""
    text = "# seagen plant config: the simulated SEA and its named effects\n" + tomli_w.dumps(cfg.to_dict())
    write_text(path, text)
