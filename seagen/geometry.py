"""Actuator geometry and sensor conversions: Eq. 2-6 of the paper, in one place."""

from __future__ import annotations

import numpy as np

# --- Facts from the paper -------------------------------------------------------------------------
SPRING_N_PER_MM = 4.2  # k_s, §IV-A
MM_PER_COUNT = 20.0 / (380.0 * 12.0)  # Eq. 3: 0.00438596 mm of nut travel per encoder count
POT_DEG_PER_COUNT = 53.12195 / 4096.0  # Eq. 4-5: 0.012969 deg per ADC count
POT_OFFSET_DEG = -5.0  # Eq. 5: -20 deg mechanical offset + 15 deg start angle
ANGLE_MIN_DEG, ANGLE_MAX_DEG = 5.0, 28.0  # range of the contact angle (Eq. 6)
R_L_SPLIT_DEG = 16.0  # horizontal load cell up to here, vertical above (Eq. 6)
ADC_MAX = 4095

# --- Chosen here (the paper gives no number); plausible for the RML glove's index finger ----------
CB_MM = 36.0  # pivot-to-shaft lever CB of Eq. 2
CE_MM = 12.0  # constant offset CE of Eq. 2
HOME_DEG = ANGLE_MIN_DEG  # the linkage rests at 5 deg with the spring unloaded
# DE at home: zero compression at 5 deg; DE shrinks as the nut advances (enc grows).
DE_HOME_MM = float(np.cos(np.radians(HOME_DEG)) * CB_MM + CE_MM)

# R_l (Eq. 6): H_fit, 5th order in (angle - 5 deg) on 5-16 deg; V_fit, 2nd order in (angle - 16 deg)
# on 16-28 deg, continuous in value and slope at 16 deg. Tip force = R_l * force at the SEA shaft.
H_FIT = (0.55, 0.032, -0.0031, 0.00021, -8.0e-6, 1.2e-7)  # ascending powers of (angle - 5)


def _h_fit(angle_deg: np.ndarray) -> np.ndarray:
    """Horizontal-mount ratio H_fit (5th-order polynomial)."""
    return np.polynomial.polynomial.polyval(np.asarray(angle_deg) - ANGLE_MIN_DEG, H_FIT)


_H16 = float(_h_fit(np.array(R_L_SPLIT_DEG)))
_DH16 = float(
    np.polynomial.polynomial.polyval(R_L_SPLIT_DEG - ANGLE_MIN_DEG, np.polynomial.polynomial.polyder(H_FIT))
)
V_FIT = (_H16, _DH16, -0.0009)  # ascending powers of (angle - 16): continuous with H_fit at 16 deg


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
