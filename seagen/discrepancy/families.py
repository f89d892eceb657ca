"""Independent benchmark families: effects in forms the catalogue does not use, and mis-set bases.

Each family's effect is written here, on its own: the truth plant switches the catalogue effect it
stands in for off and adds its own law (a Plant subclass reusing only the motor, spring, linkage and
sensor mechanics). The catalogue effect(s) each family should be named as are fixed below, before any
run. The mis-set family hides nothing: its base has one or two parameters off by 20-60 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from seagen import fmath
from seagen.actuator import Actuator, default_actuator
from seagen.plant import Plant, PlantConfig, pick
from seagen.plant.config import pot_full_scale


class MemoryFriction(Plant):
    """Friction with a bristle state: the Coulomb band builds up as 1 - exp(-s/x0) with travel s since the
    last reversal of the shaft (a force loss that opens at reversals)."""

    fc: float  # N, the band's height (drawn per case: FAMILIES' range)
    x0: float  # mm, the travel over which it builds up

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's other friction plus the memory band."""
        fwd, rev = super().friction_limits(angle_deg)
        s = getattr(self, "_travel", np.zeros_like(fwd))
        band = self.fc * (1 - fmath.exp(-s / self.x0))
        return fwd + band, rev + 0.6 * band

    def step(self, motor_v: Any) -> None:
        """Step, then update the travel since the last reversal."""
        y0, v0 = self.shaft_mm.copy(), getattr(self, "_vsign", np.zeros_like(self.shaft_mm))
        super().step(motor_v)
        dy = self.shaft_mm - y0
        sign = np.sign(dy)
        flip = (sign != 0) & (sign != v0) & (v0 != 0)
        self._travel = np.where(flip, 0.0, getattr(self, "_travel", np.zeros_like(dy)) + np.abs(dy))
        self._vsign = np.where(sign != 0, sign, v0)


class ExpStribeck(Plant):
    """Break-away friction of another shape: extra * exp(-|v|/vs) (the catalogue's is Gaussian in v)."""

    extra, vs = 1.5, 0.8

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's friction plus the exponential low-speed boost."""
        fwd, rev = super().friction_limits(angle_deg)
        boost = self.extra * fmath.exp(-np.abs(getattr(self, "v_shaft", np.zeros_like(fwd))) / self.vs)
        return fwd + boost, rev + boost


class CubicStructure(Plant):
    """Hardening written in the deflection domain: d = F/k + c F^3 (the catalogue's is F/k + beta F^2)."""

    k, c = 35.0, 2.5e-4

    def structure_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Invert d(F) by Newton per element; slope from the inverse derivative (elements idx)."""
        yc = pick(self.y_contact, idx)
        d = np.maximum(y - yc, 0.0)
        k, c = self.k, self.c
        f = np.minimum(d * k, fmath.cbrt(d / c))
        for _ in range(30):
            f = np.maximum(f - (f / k + c * (f * f * f) - d) / (1 / k + 3 * c * f**2), 0.0)
        return f, np.where(y > yc, 1.0 / (1 / k + 3 * c * f**2), 0.0)


class LaggedCell(Plant):
    """A load cell behind a first-order lag of time constant tau (a delay of fractional samples)."""

    tau = 0.02

    def read(self):
        """The reading, low-passed at the sample rate (the actuator's loop rate)."""
        s = super().read()
        prev = getattr(self, "_lc", s.load_cell_n)
        a = 1 - math.exp(-1.0 / self.cfg.actuator.loop_hz / self.tau)
        self._lc = prev + a * (s.load_cell_n - prev)
        s.load_cell_n, s.force_n = self._lc.copy(), self._lc / self.ratio
        return s


class DriftingOffset(Plant):
    """A load-cell zero that drifts over the session: o0 + rate * (session time), trials back to back."""

    o0, rate = 0.5, 0.05  # N, N/s

    def read(self):
        """The reading plus the drifting zero (trial i starts 4 s after trial i-1)."""
        s = super().read()
        session = self.t + 4.0 * np.arange(s.load_cell_n.size)
        s.load_cell_n = s.load_cell_n + self.o0 + self.rate * session
        s.force_n = s.load_cell_n / self.ratio
        return s


class LaggedPotBias(Plant):
    """A pot bias that follows |motor current| through two cascaded lags (the catalogue's has one)."""

    gain: float  # pot counts per unit current (drawn per case, FAMILIES' range: shares of full scale)
    tau: float  # s

    def read(self):
        """The reading plus the doubly lagged bias (updated per sample)."""
        s = super().read()
        a = 1 - math.exp(-1.0 / self.cfg.actuator.loop_hz / self.tau)
        b1 = getattr(self, "_b1", np.zeros_like(self.current))
        b2 = getattr(self, "_b2", np.zeros_like(self.current))
        self._b1 = b1 + a * (self.gain * np.abs(self.current) - b1)
        self._b2 = b2 + a * (self._b1 - b2)
        s.pot = np.clip(np.rint(s.pot + self._b2), 0, self.geo.adc_max).astype(np.int64)
        return s


@dataclass(frozen=True)
class Family:
    """A family: its truth plant class, the catalogue effect it replaces, parameter ranges, expected names."""

    cls: type[Plant]
    replaces: str | None
    ranges: dict[str, tuple[float, float]]
    expected: frozenset[str]
    pot_counts: frozenset[str] = frozenset()  # parameters in pot counts: ranges as shares of full scale

    def bounds(self, act: Actuator | None = None) -> dict[str, tuple[float, float]]:
        """The parameter ranges in the plant's units on actuator `act` (the paper's when None)."""
        fs = pot_full_scale(act or default_actuator())
        return {
            k: (lo * fs, hi * fs) if k in self.pot_counts else (lo, hi) for k, (lo, hi) in self.ranges.items()
        }


FAMILIES: dict[str, Family] = {
    "memory_friction": Family(
        MemoryFriction,
        "actuator_friction",
        {"fc": (2.0, 3.5), "x0": (0.02, 0.06)},
        frozenset({"actuator_friction"}),
    ),
    "exp_stribeck": Family(
        ExpStribeck, None, {"extra": (1.0, 2.5), "vs": (0.5, 1.5)}, frozenset({"stribeck_friction"})
    ),
    "cubic_structure": Family(
        CubicStructure,
        "series_compliance",
        {"k": (25.0, 45.0), "c": (1.5e-4, 4e-4)},
        frozenset({"series_compliance"}),
    ),
    "lagged_cell": Family(LaggedCell, None, {"tau": (0.015, 0.05)}, frozenset({"transport_delay"})),
    "drifting_offset": Family(
        DriftingOffset, None, {"o0": (0.3, 1.0), "rate": (0.02, 0.08)}, frozenset({"load_cell_offset"})
    ),
    "lagged_pot_bias": Family(
        LaggedPotBias,
        "pot_voltage_drop",
        {"gain": (0.01953125, 0.048828125), "tau": (0.04, 0.12)},  # gain: 80 to 200 counts of 12 bits
        frozenset({"pot_voltage_drop"}),
        frozenset({"gain"}),
    ),
}
# Mis-set bases: (effect, parameter) pairs a base may get wrong; one or two per case, off by 20-60 %.
MISSET = (
    ("actuator_friction", "force_n"),
    ("series_compliance", "k_n_per_mm"),
    ("pot_voltage_drop", "counts_per_unit_current"),
    ("linkage_friction", "c1_n"),
)


def family_case(
    name: str, seed: int, act: Actuator | None = None
) -> tuple[type[Plant], PlantConfig, PlantConfig, dict[str, float]]:
    """(plant class, truth config, base config, drawn parameters) of one case of family `name` on actuator
    `act` (the paper's when None)."""
    rng = np.random.default_rng(seed)
    fam = FAMILIES[name]
    default = PlantConfig(actuator=act or default_actuator())
    params = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in fam.bounds(default.actuator).items()}
    cls = type(f"{fam.cls.__name__}_{seed}", (fam.cls,), params)
    truth = default if fam.replaces is None else default.with_effect(fam.replaces, False)
    return cls, truth, truth, params


def misset_case(
    seed: int, act: Actuator | None = None
) -> tuple[PlantConfig, PlantConfig, dict[str, tuple[float, float]]]:
    """(truth = the default plant of actuator `act` (the paper's when None), base with one or two
    parameters off by 20-60 %, {key: (base, truth)})."""
    rng = np.random.default_rng(seed)
    picks = rng.choice(len(MISSET), size=1 + int(rng.integers(2)), replace=False)
    truth = base = PlantConfig(actuator=act or default_actuator())
    wrong = {}
    for i in picks:
        e, p = MISSET[int(i)]
        true = float(getattr(truth.effect(e), p))
        factor = 1 + float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.2, 0.6))
        base = base.with_effect(e, True, **{p: true * factor})
        wrong[f"{e}.{p}"] = (true * factor, true)
    return truth, base, wrong
