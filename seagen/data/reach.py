"""How long a calibration push takes on a described actuator, and the designs too slow to calibrate.

A push at V volts drives the nut at v_max (V/V_s - F/F_stall) (the plant's motor law, F the load: the force
reached plus the actuator's friction), first across the free linkage to the load cell and then compressing
the spring until the force reaches its peak, so its time is

    t(V) = y_c / (v_max (a - f_f))  +  F_stall / (k v_max) ln((a - f_f) / (a - f_f - f_p)),   a = V / V_s

with y_c the shaft's travel to contact at the top angle, k the spring, f the forces over F_stall (series
compliance only lengthens it). A design that would need more than MAX_PUSH_S to push to its force range at
full supply is refused with its numbers before any data are made.
"""

from __future__ import annotations

import math

from seagen.actuator import Actuator
from seagen.geometry import geometry
from seagen.plant.config import Motor

MAX_PUSH_S = 60.0  # longest push to force_max_n (at full supply) a calibration protocol may ask for


def push_time(act: Actuator, volts: float, peak_n: float) -> float:
    """Estimated seconds from rest to `peak_n` at `volts` on `act` (infinite when the motor stalls first)."""
    m, geo = Motor.of(act), geometry(act)
    a, f_f, f_p = volts / m.supply_v, act.friction_n / m.stall_force_n, peak_n / m.stall_force_n
    if a - f_f - f_p <= 0:
        return math.inf
    v_max = m.v_max_mm_s
    approach = float(geo.shaft_advance_mm(geo.angle_max_deg)) / (v_max * (a - f_f))
    load = m.stall_force_n / (act.stiffness_n_per_mm * v_max) * math.log((a - f_f) / (a - f_f - f_p))
    return approach + load


def reach_problem(act: Actuator) -> str | None:
    """Why the calibration protocol cannot reach `act`'s force range in time, with the numbers, or None."""
    m, c = Motor.of(act), act.control
    t = push_time(act, m.supply_v, c.force_max_n)
    if t <= MAX_PUSH_S:
        return None
    comp = c.force_max_n / act.stiffness_n_per_mm
    return (
        f"a push to control.force_max_n {c.force_max_n:g} N takes {t:.0f} s at the full supply "
        f"({m.v_max_mm_s:.3g} mm/s at the nut without load, {comp:.3g} mm of spring compression), more than "
        f"the {MAX_PUSH_S:g} s a calibration push may take: a faster motor or gearbox (motor.no_load_rpm, "
        "motor.gear_ratio), a longer transmission.lead_mm, a stiffer spring or a lower control.force_max_n"
    )
