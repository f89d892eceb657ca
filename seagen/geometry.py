"""Actuator geometry and sensor conversions: Eq. 2-6 of the paper, in one place."""

from __future__ import annotations

import numpy as np

from seagen.actuator import default_actuator

# Every number comes from the actuator description (seagen/actuators/paper.toml: the paper's SEA, with the
# values the paper does not give chosen there, each with a comment).
ACTUATOR = default_actuator()
SPRING_N_PER_MM = ACTUATOR.stiffness_n_per_mm  # k_s, §IV-A
MM_PER_COUNT = ACTUATOR.mm_per_count  # Eq. 3: 0.00438596 mm of nut travel per encoder count
POT_DEG_PER_COUNT = ACTUATOR.pot_deg_per_count  # Eq. 4-5: 0.012969 deg per ADC count
POT_OFFSET_DEG = ACTUATOR.pot.offset_deg  # Eq. 5
ANGLE_MIN_DEG, ANGLE_MAX_DEG = ACTUATOR.linkage.angle_min_deg, ACTUATOR.linkage.angle_max_deg  # Eq. 6
R_L_SPLIT_DEG = ACTUATOR.linkage.split_deg  # horizontal load cell up to here, vertical above (Eq. 6)
ADC_MAX = ACTUATOR.adc_max

CB_MM = ACTUATOR.linkage.cb_mm  # pivot-to-shaft lever CB of Eq. 2
CE_MM = ACTUATOR.linkage.ce_mm  # constant offset CE of Eq. 2
HOME_DEG = ACTUATOR.linkage.home_deg  # the linkage rests here with the spring unloaded
# DE at home: zero compression at HOME_DEG; DE shrinks as the nut advances (enc grows).
DE_HOME_MM = float(np.cos(np.radians(HOME_DEG)) * CB_MM + CE_MM)

# R_l (Eq. 6): H_fit in (angle - ANGLE_MIN_DEG) up to the split; V_fit in (angle - split) above it,
# continuous in value and slope at the split. Tip force = R_l * force at the SEA shaft.
H_FIT = ACTUATOR.linkage.h_fit  # ascending powers of (angle - ANGLE_MIN_DEG)


def _h_fit(angle_deg: np.ndarray) -> np.ndarray:
    """Horizontal-mount ratio H_fit (5th-order polynomial)."""
    return np.polynomial.polynomial.polyval(np.asarray(angle_deg) - ANGLE_MIN_DEG, H_FIT)


_H16 = float(_h_fit(np.array(R_L_SPLIT_DEG)))
_DH16 = float(
    np.polynomial.polynomial.polyval(R_L_SPLIT_DEG - ANGLE_MIN_DEG, np.polynomial.polynomial.polyder(H_FIT))
)
V_FIT = (_H16, _DH16, *ACTUATOR.linkage.v_fit_higher)  # ascending powers of (angle - split): continuous at it


def linkage_ratio(angle_deg: np.ndarray | float) -> np.ndarray:
    """R_l of Eq. 6: tip force per newton at the SEA output shaft, 5-28 deg."""
    a = np.clip(np.asarray(angle_deg, dtype=float), ANGLE_MIN_DEG, ANGLE_MAX_DEG)
    v = np.polynomial.polynomial.polyval(a - R_L_SPLIT_DEG, V_FIT)
    return np.where(a <= R_L_SPLIT_DEG, _h_fit(a), v)


def angle_from_pot(pot: np.ndarray | float) -> np.ndarray:
    """Eq. 5: linkage angle (deg) from the raw 12-bit pot reading."""
    return np.asarray(pot, dtype=float) * POT_DEG_PER_COUNT + POT_OFFSET_DEG


def pot_from_angle(angle_deg: np.ndarray | float) -> np.ndarray:
    """Inverse of Eq. 5 (continuous pot counts, not yet quantized)."""
    return (np.asarray(angle_deg, dtype=float) - POT_OFFSET_DEG) / POT_DEG_PER_COUNT


def nut_travel_mm(enc: np.ndarray | float) -> np.ndarray:
    """Eq. 3: nut advance (mm) from encoder counts."""
    return np.asarray(enc, dtype=float) * MM_PER_COUNT


def compression_mm(angle_deg: np.ndarray | float, enc: np.ndarray | float) -> np.ndarray:
    """Eq. 2: spring compression cos(ABC)*CB - (DE - CE), with DE = DE_home - nut travel."""
    de = DE_HOME_MM - nut_travel_mm(enc)
    return np.cos(np.radians(np.asarray(angle_deg, dtype=float))) * CB_MM - (de - CE_MM)


def shaft_advance_mm(angle_deg: np.ndarray | float) -> np.ndarray:
    """Output-shaft advance from home implied by the linkage angle (inverse of the free linkage)."""
    return CB_MM * (np.cos(np.radians(HOME_DEG)) - np.cos(np.radians(np.asarray(angle_deg, dtype=float))))


def angle_from_shaft(y_mm: np.ndarray | float) -> np.ndarray:
    """Linkage angle (deg) for an output-shaft advance y (inverse of shaft_advance_mm)."""
    c = np.cos(np.radians(HOME_DEG)) - np.asarray(y_mm, dtype=float) / CB_MM
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
