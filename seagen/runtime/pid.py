"""Python twin of c_runtime/sea_pid.c: the same integers, vectorized over a batch (numpy int64)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from seagen.actuator import Control, default_actuator
from seagen.errors import UserError
from seagen.runtime.actq import act_q_of
from seagen.runtime.fixed import COMP_FRAC_BITS, clamp, rshift_rne, sat32

GAIN_FRAC = 12  # SEA_PID_GAIN_FRAC
ALPHA_FRAC = 16  # SEA_PID_ALPHA_FRAC
OUT_FRAC = 16  # SEA_PID_OUT_FRAC
TERM_SHIFT = GAIN_FRAC + COMP_FRAC_BITS - OUT_FRAC
MOTOR_MAX_MV = act_q_of().motor_max_mv  # the paper's actuator: its supply (sea_act.motor_max_mv)
TICK_S = 1.0 / act_q_of().loop_hz  # its controller tick (100 Hz)


I32_MAX = 2**31 - 1
# PidParams.from_si's SI argument -> the description's [control] field (pid_si reads them; seagen tune
# writes them)
SI_FIELDS = {
    "kp_v_mm": "kp_v_per_mm",
    "ki_v_mm_s": "ki_v_per_mm_s",
    "kd_v_s_mm": "kd_v_s_per_mm",
    "d_alpha": "d_alpha",
    "margin_mm": "margin_mm",
    "limit_v": "limit_v",
}
# the gains: their unit and power of the tick in the Q12 integer (kp per mm, ki per mm per tick, kd per mm
# per tick^-1)
GAINS = {"kp_v_mm": ("V/mm", 0), "ki_v_mm_s": ("V/(mm s)", 1), "kd_v_s_mm": ("V s/mm", -1)}


class GainRangeError(UserError):
    """A PID gain whose Q12 integer does not fit the C's int32 field at this loop rate (exit 2); `why` is
    the reason alone, the message `where` (the actuator) before it."""

    def __init__(self, why: str, where: str = "") -> None:
        super().__init__(f"{where}{why}")
        self.why = why


def gain_max_si(tick_s: float) -> dict[str, float]:
    """The largest value of each gain (GAINS, SI) whose Q12 integer fits int32 at tick `tick_s`."""
    return {k: I32_MAX / (1000.0 * (1 << GAIN_FRAC) * tick_s**p) for k, (_u, p) in GAINS.items()}


@dataclass(frozen=True)
class PidParams:
    """sea_pid_params: gains Q12 (mV/mm, mV/(mm tick), mV tick/mm), alpha Q16, margin Q16 mm, range mV."""

    kp: int
    ki: int
    kd: int
    d_alpha: int
    margin: int
    out_min: int
    out_max: int

    @classmethod
    def from_si(
        cls,
        kp_v_mm: float,
        ki_v_mm_s: float,
        kd_v_s_mm: float,
        d_alpha: float,
        *,
        margin_mm: float,
        limit_v: float,
        max_mv: int,
        tick_s: float,
    ) -> PidParams:
        """Quantize gains given in V/mm, V/(mm s), V s/mm at the tick `tick_s` (rounded to nearest); the
        output is limited to +-limit_v within the motor's +-max_mv (sea_act.motor_max_mv). No default: each
        is the actuator's (pid_si of its [control], ActQ.motor_max_mv, 1 / its loop_hz)."""
        q = float(1 << GAIN_FRAC)
        gains = {
            "kp_v_mm": round(kp_v_mm * 1000 * q),
            "ki_v_mm_s": round(ki_v_mm_s * 1000 * tick_s * q),
            "kd_v_s_mm": round(kd_v_s_mm * 1000 / tick_s * q),
        }
        si = {"kp_v_mm": kp_v_mm, "ki_v_mm_s": ki_v_mm_s, "kd_v_s_mm": kd_v_s_mm}
        for k, v in gains.items():
            if abs(v) > I32_MAX:
                unit = GAINS[k][0]
                raise GainRangeError(
                    f"control.{SI_FIELDS[k]} {si[k]:g} {unit} at {1.0 / tick_s:g} Hz does not fit the C's "
                    f"Q12 gain in int32 (at most {gain_max_si(tick_s)[k]:.4g} {unit} at this loop rate)"
                )
        lim = min(round(limit_v * 1000), max_mv)
        return cls(
            kp=gains["kp_v_mm"],
            ki=gains["ki_v_mm_s"],
            kd=gains["kd_v_s_mm"],
            d_alpha=round(d_alpha * (1 << ALPHA_FRAC)),
            margin=round(margin_mm * (1 << COMP_FRAC_BITS)),
            out_min=-lim,
            out_max=lim,
        )

    def as_tuple(self) -> tuple[int, ...]:
        """Field values in C declaration order."""
        return (self.kp, self.ki, self.kd, self.d_alpha, self.margin, self.out_min, self.out_max)


def pid_si(c: Control) -> dict[str, Any]:
    """The PID settings of a description's [control] table as PidParams.from_si arguments."""
    return {k: getattr(c, field) for k, field in SI_FIELDS.items()}


# The paper's description's gains, tuned on its simulated plant (c_runtime/README.md "Tuned gains";
# seagen tune).
DEFAULT_PID_SI: dict[str, Any] = pid_si(default_actuator().control)
DEFAULT_PID = PidParams.from_si(**DEFAULT_PID_SI, max_mv=MOTOR_MAX_MV, tick_s=TICK_S)


@dataclass(frozen=True)
class PidState:
    """sea_pid_state for a batch: integrator Q16 mV, filtered rate Q16 mm/tick, last meas, last out mV."""

    integ: np.ndarray
    d_filt: np.ndarray
    meas_prev: np.ndarray
    out: np.ndarray


def pid_reset(p: PidParams, meas: np.ndarray | int, out: np.ndarray | int = 0) -> PidState:
    """Bumpless (re)start (sea_pid_reset): integrator = out (clamped), filter cleared, meas remembered."""
    meas = np.atleast_1d(np.asarray(meas, dtype=np.int64))
    o = np.broadcast_to(clamp(out, p.out_min, p.out_max), meas.shape).astype(np.int64)
    return PidState(o * (1 << OUT_FRAC), np.zeros_like(meas), meas.copy(), sat32(o))


def _rate(p: PidParams, s: PidState, meas: np.ndarray) -> np.ndarray:
    """Filtered measurement rate, Q16 mm per tick (sea_pid_rate)."""
    alpha = int(clamp(p.d_alpha, 0, 1 << ALPHA_FRAC))
    x = sat32(meas - s.meas_prev)
    return sat32(s.d_filt + rshift_rne(alpha * (x - s.d_filt), ALPHA_FRAC))


def pid_step(p: PidParams, s: PidState, setpoint: np.ndarray | int, meas: np.ndarray | int) -> PidState:
    """One tick (sea_pid_step); returns the new state, whose `out` is the command in mV."""
    sp = np.asarray(setpoint, dtype=np.int64)
    meas = np.broadcast_to(np.asarray(meas, dtype=np.int64), s.integ.shape)
    lo, hi = p.out_min * (1 << OUT_FRAC), p.out_max * (1 << OUT_FRAC)
    margin = max(p.margin, 0)
    e = sat32(sp - meas)
    d_filt = _rate(p, s, meas)
    e = np.where((e >= -margin) & (e <= margin), 0, e)
    pterm = rshift_rne(p.kp * e, TERM_SHIFT)
    dterm = -rshift_rne(p.kd * d_filt, TERM_SHIFT)
    inc = rshift_rne(p.ki * e, TERM_SHIFT)
    integ = clamp(s.integ + inc, lo, hi)
    u = pterm + integ + dterm
    hold = ((u > hi) & (inc > 0)) | ((u < lo) & (inc < 0))
    integ = np.where(hold, s.integ, integ)
    u = pterm + integ + dterm
    out = sat32(clamp(rshift_rne(u, OUT_FRAC), p.out_min, p.out_max))
    return PidState(integ, d_filt, meas.copy(), out)


def merge(keep_old: np.ndarray, old: PidState, new: PidState) -> PidState:
    """Per element: `old` where keep_old, else `new`."""
    return replace(
        new, **{f: np.where(keep_old, getattr(old, f), getattr(new, f)) for f in new.__dataclass_fields__}
    )
