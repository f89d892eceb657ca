"""Actuator geometry and sensor conversions: Eq. 2-6 of the paper for one actuator description."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from seagen import fmath
from seagen.actuator import Actuator, default_actuator

_P = np.polynomial.polynomial


class Geometry:
    """Eq. 2-6 of one actuator description; every number comes from it (`seagen/actuator.py`)."""

    def __init__(self, act: Actuator) -> None:
        self.actuator = act
        lk = act.linkage
        self.spring_n_per_mm = act.stiffness_n_per_mm  # k_s
        self.friction_n = act.friction_n  # F_fa of Eq. 1: what the textbook estimate compensates
        self.mm_per_count = act.mm_per_count  # Eq. 3: nut travel per encoder count
        self.pot_deg_per_count = act.pot_deg_per_count  # Eq. 4-5
        self.pot_offset_deg = act.pot.offset_deg  # Eq. 5
        self.angle_min_deg, self.angle_max_deg = lk.angle_min_deg, lk.angle_max_deg  # Eq. 6
        self.split_deg = lk.split_deg  # horizontal load cell up to here, vertical above (Eq. 6)
        self.adc_max = act.adc_max
        self.cb_mm, self.home_deg = lk.cb_mm, lk.home_deg  # Eq. 2
        # DE - CE at home: zero compression at home_deg; it shrinks as the nut advances (enc grows). Eq. 2's
        # constant CE cancels out of every compression, so the description does not carry it.
        self.de_home_mm = float(fmath.cos(np.radians(lk.home_deg)) * lk.cb_mm)
        # R_l (Eq. 6): H_fit in (angle - angle_min) up to the split; V_fit in (angle - split) above it,
        # continuous in value and slope at the split. Tip force = R_l * force at the SEA shaft.
        self.h_fit = lk.h_fit
        at_split = self.split_deg - self.angle_min_deg
        value, slope = _P.polyval(at_split, self.h_fit), _P.polyval(at_split, _P.polyder(self.h_fit))
        self.v_fit = (float(value), float(slope), *lk.v_fit_higher)

    def linkage_ratio(self, angle_deg: np.ndarray | float) -> np.ndarray:
        """R_l of Eq. 6: tip force per newton at the SEA output shaft, clipped to the angle range."""
        a = np.clip(np.asarray(angle_deg, dtype=float), self.angle_min_deg, self.angle_max_deg)
        h = _P.polyval(a - self.angle_min_deg, self.h_fit)
        return np.where(a <= self.split_deg, h, _P.polyval(a - self.split_deg, self.v_fit))

    def angle_from_pot(self, pot: np.ndarray | float) -> np.ndarray:
        """Eq. 5: linkage angle (deg) from the raw pot reading."""
        return np.asarray(pot, dtype=float) * self.pot_deg_per_count + self.pot_offset_deg

    def pot_from_angle(self, angle_deg: np.ndarray | float) -> np.ndarray:
        """Inverse of Eq. 5 (continuous pot counts, not yet quantized)."""
        return (np.asarray(angle_deg, dtype=float) - self.pot_offset_deg) / self.pot_deg_per_count

    def nut_travel_mm(self, enc: np.ndarray | float) -> np.ndarray:
        """Eq. 3: nut advance (mm) from encoder counts."""
        return np.asarray(enc, dtype=float) * self.mm_per_count

    def compression_mm(self, angle_deg: np.ndarray | float, enc: np.ndarray | float) -> np.ndarray:
        """Eq. 2: spring compression cos(ABC)*CB - (DE - CE), with DE - CE = (DE - CE)_home - nut travel."""
        return self.linkage_mm(angle_deg) + self.nut_travel_mm(enc)

    def linkage_mm(self, angle_deg: np.ndarray | float) -> np.ndarray:
        """The linkage term of Eq. 2, cos(ABC)*CB - (DE - CE)_home: the compression at encoder count 0."""
        return fmath.cos(np.radians(np.asarray(angle_deg, dtype=float))) * self.cb_mm - self.de_home_mm

    def shaft_advance_mm(self, angle_deg: np.ndarray | float) -> np.ndarray:
        """Output-shaft advance from home implied by the linkage angle (inverse of the free linkage)."""
        a = np.radians(np.asarray(angle_deg, dtype=float))
        return self.cb_mm * (fmath.cos(np.radians(self.home_deg)) - fmath.cos(a))

    def angle_from_shaft(self, y_mm: np.ndarray | float) -> np.ndarray:
        """Linkage angle (deg) for an output-shaft advance y (inverse of shaft_advance_mm)."""
        c = fmath.cos(np.radians(self.home_deg)) - np.asarray(y_mm, dtype=float) / self.cb_mm
        return np.degrees(fmath.arccos(np.clip(c, -1.0, 1.0)))


@lru_cache(maxsize=32)
def geometry(act: Actuator | None = None) -> Geometry:
    """The geometry of `act` (the paper's actuator when None), built once per description."""
    return Geometry(default_actuator() if act is None else act)
