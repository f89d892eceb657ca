"""How long a calibration push takes on a described actuator: the volts and the time the protocol gives it.

A push at V volts drives the nut at v_max (V/V_s - F/F_stall) (the plant's motor law, F the load: the force
reached plus the actuator's friction), first across the free linkage to the load cell and then compressing
the spring until the force reaches its peak, so its time is

    t(V) = y_c / (v_max (a - f_f))  +  F_stall / (k v_max) ln((a - f_f) / (a - f_f - f_p)),   a = V / V_s

with y_c the shaft's travel to contact at the top angle, k the spring, f the forces over F_stall (series
compliance only lengthens it). The paper's moves were timed for its motor: on a design whose push at the
paper's stall force per volt (`volts_scale`) would take more than SLACK times the paper's same move, the
volts rise until it does not, up to the supply (`push_volts`); where even the supply is slower, the
protocol's split durations and trial cap grow by that factor (`pace`). A design that would need more than
MAX_PUSH_S to push to its force range at full supply is refused with its numbers before any data are made.
The retracts likewise: one that would unload the spring more than SLACK times slower than the paper's same
retract gets more volts, up to the supply (`retract_volts`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from seagen.actuator import Actuator, default_actuator
from seagen.geometry import geometry
from seagen.plant.config import Motor

MAX_PUSH_S = 60.0  # longest push to force_max_n (at full supply) a calibration protocol may ask for
REFERENCE_MOVE = (2.5, 17.0)  # the paper's first push: volts, peak N (85 % of its 20 N range)
# A push may take up to this many times the paper's same move before its volts rise (the paper's own five
# moves span 0.6-2.2 s by this estimate): a design near the paper's keeps its protocol as it is.
SLACK = 1.5


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


def _paper_time(peak_share: float, volts: float) -> float:
    """The paper's push time for a move to that share of its force range at its volts."""
    paper = default_actuator()
    return push_time(paper, volts, peak_share * paper.control.force_max_n)


def retract_time(act: Actuator, volts: float, peak_n: float) -> float:
    """Estimated seconds for a retract at `volts` (negative) to unload the spring from `peak_n` to zero on
    `act`: the spring helps the motor back, the friction holds it, so the nut runs at
    v_max (a + (F - F_f) / F_stall) and t = F_stall / (k v_max) ln((a - f_f + f_p) / (a - f_f)) (infinite
    where the motor cannot overcome the friction once the spring is slack)."""
    m = Motor.of(act)
    a, f_f, f_p = abs(volts) / m.supply_v, act.friction_n / m.stall_force_n, peak_n / m.stall_force_n
    if a - f_f <= 0:
        return math.inf
    return m.stall_force_n / (act.stiffness_n_per_mm * m.v_max_mm_s) * math.log((a - f_f + f_p) / (a - f_f))


def _raised(time: Callable[[float], float], volts: float, top: float, want: float) -> float:
    """`volts` (>= 0), or more where time(volts) > want: the least that does not, up to `top`."""
    if time(min(volts, top)) <= want * (1 + 1e-9):
        return min(volts, top)
    if time(top) >= want:
        return top
    lo, hi = volts, top
    for _ in range(60):  # bisection: the time falls as the volts rise
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if time(mid) > want else (lo, mid)
    return hi


def push_volts(act: Actuator, volts: float, peak_n: float, paper_volts: float) -> float:
    """The push's volts on `act`: `volts` (the paper's stall force per volt), or more where that push would
    take more than SLACK times the paper's same move (at `paper_volts`), up to the supply."""
    want = SLACK * _paper_time(peak_n / act.control.force_max_n, paper_volts)
    return _raised(lambda v: push_time(act, v, peak_n), volts, act.motor.supply_v, want)


def retract_volts(act: Actuator, volts: float, peak_n: float, paper_volts: float) -> float:
    """The retract's volts (negative) on `act`: `volts` (scaled like the push's), or more negative where
    unloading the spring from `peak_n` would take more than SLACK times the paper's same retract (at
    `paper_volts`, from the same share of its range), down to minus the supply."""
    paper = default_actuator()
    share = peak_n / act.control.force_max_n
    want = SLACK * retract_time(paper, paper_volts, share * paper.control.force_max_n)
    return -_raised(lambda v: retract_time(act, v, peak_n), abs(volts), act.motor.supply_v, want)


def stretch(act: Actuator, volts: float, peak_n: float, paper_volts: float) -> float:
    """How many times longer (>= 1) a push of `act` at `volts` to `peak_n` takes than the paper's same move
    (at `paper_volts`; exactly 1 on the paper's actuator and on any design at least as brisk)."""
    paper = _paper_time(peak_n / act.control.force_max_n, paper_volts)
    return max(1.0, push_time(act, volts, peak_n) / paper)


def pace(act: Actuator | None = None) -> float:
    """Factor (>= 1) on the protocol's split durations and trial cap for `act`: how much longer than SLACK
    times the paper's its reference push takes at full supply (exactly 1 for a design near the paper's)."""
    act = act or default_actuator()
    volts, peak = REFERENCE_MOVE
    share = peak / default_actuator().control.force_max_n
    mine = push_time(act, act.motor.supply_v, share * act.control.force_max_n)
    return max(1.0, mine / (SLACK * _paper_time(share, volts)))


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
