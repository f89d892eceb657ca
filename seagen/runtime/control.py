"""Python twin of c_runtime/sea_control.c: the two-level controller, vectorized over a batch of actuators."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from seagen.actuator import Actuator, default_actuator
from seagen.c_runtime import defines
from seagen.runtime.actq import ActQ, act_q, act_q_of
from seagen.runtime.fixed import FORCE_FRAC_BITS, compression_q16, div_rne, rshift_rne, sat32
from seagen.runtime.pid import (
    DEFAULT_PID,
    GainRangeError,
    PidParams,
    PidState,
    merge,
    pid_reset,
    pid_si,
    pid_step,
)

_C = defines("sea_control.h")  # the header is the one definition of the controller's constants
FORCE_FRAC = FORCE_FRAC_BITS  # SEA_FORCE_FRAC_BITS: desired force in Q16 N
PRED_AVG_MAX = _C["SEA_CTRL_PRED_AVG_MAX"]
PAPER = act_q_of()  # the paper's actuator: the defaults below
POT_STUCK_TICKS = PAPER.pot_stuck_ticks  # its defaults (sea_act.pot_stuck_ticks, .enc_jump_max)
ENC_JUMP_MAX = PAPER.enc_jump_max  # ceil(2 x 32,300 rpm x 12 CPR / 60 / 100 Hz)
FAULT_POT_STUCK_LOW, FAULT_POT_STUCK_HIGH = _C["SEA_FAULT_POT_STUCK_LOW"], _C["SEA_FAULT_POT_STUCK_HIGH"]
FAULT_ENC_JUMP, FAULT_FORCE_RANGE = _C["SEA_FAULT_ENC_JUMP"], _C["SEA_FAULT_FORCE_RANGE"]
FAULT_NAMES = {
    FAULT_POT_STUCK_LOW: "pot_stuck_low",
    FAULT_POT_STUCK_HIGH: "pot_stuck_high",
    FAULT_ENC_JUMP: "enc_jump",
    FAULT_FORCE_RANGE: "force_range",
}
MLP_PRED_AVG = (
    9  # MLP predictors: desired = mean of the last 9 predictions (smooths the pot noise in its inputs)
)
# The paper's calibrated range of the desired force at the shaft (its description's control.force_max_n).
FORCE_RANGE_N = (0.0, PAPER.control.force_max_n)

# (enc, pot, force_q16) int64 arrays -> desired compression, Q16 mm (int64 array)
Predictor = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def q16(x: float) -> int:
    """A float in Q16 (rounded half to even), as a Python int."""
    return int(np.rint(x * (1 << 16)))


@dataclass(frozen=True)
class KinParams:
    """sea_kin_params: actuator friction Q16 N, 1/spring rate Q16 mm per N (the paper's by default)."""

    friction_q16: int = q16(default_actuator().friction_n)
    inv_k_q16: int = q16(1 / default_actuator().stiffness_n_per_mm)

    @classmethod
    def of(cls, act: Actuator) -> KinParams:
        """The kinematic predictor's constants of actuator `act` (its friction and spring)."""
        return cls(q16(act.friction_n), q16(1 / act.stiffness_n_per_mm))


def predict_kinematic(k: KinParams) -> Predictor:
    """Twin of sea_predict_kinematic: compression = (F + friction) / k_s in Q16 mm."""

    def f(enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
        return sat32(
            rshift_rne(sat32(np.asarray(force_q16, np.int64) + k.friction_q16) * k.inv_k_q16, FORCE_FRAC)
        )

    return f


@dataclass(frozen=True)
class ControlConfig:
    """sea_control_config (the predictor is a twin callable, or None for an externally supplied one)."""

    pid: PidParams = DEFAULT_PID
    act: ActQ = PAPER
    predictor: Predictor | None = None
    predict_every: int = 1
    pred_avg: int = 1  # predictions averaged into the desired compression (1..10)
    force_min: int = q16(FORCE_RANGE_N[0])
    force_max: int = q16(FORCE_RANGE_N[1])
    enc_jump_max: int = ENC_JUMP_MAX
    pot_stuck_ticks: int = POT_STUCK_TICKS

    @classmethod
    def for_act(cls, a: ActQ, **kw: Any) -> ControlConfig:
        """A configuration of actuator `a`: its PID gains and desired-force range, its default encoder-jump
        and stuck-pot bounds."""
        if "pid" not in kw:
            try:
                kw["pid"] = PidParams.from_si(
                    **pid_si(a.control), max_mv=a.motor_max_mv, tick_s=1.0 / a.loop_hz
                )
            except GainRangeError as e:
                raise GainRangeError(e.why, f"actuator '{a.name}': ") from None
        kw.setdefault("force_max", q16(a.control.force_max_n))
        return cls(act=a, enc_jump_max=a.enc_jump_max, pot_stuck_ticks=a.pot_stuck_ticks, **kw)


@dataclass(frozen=True)
class ControlState:
    """sea_control_state for a batch (int64 arrays)."""

    pid: PidState
    pot_sum: np.ndarray
    pot_idx: np.ndarray
    pot_avg: np.ndarray
    pred_count: np.ndarray
    pred_buf: np.ndarray
    pred_idx: np.ndarray
    enc_prev: np.ndarray
    stuck_lo: np.ndarray
    stuck_hi: np.ndarray
    desired: np.ndarray
    comp: np.ndarray
    fault: np.ndarray
    out: np.ndarray


def _where(mask: np.ndarray, a: ControlState, b: ControlState) -> ControlState:
    """Per element: `a` where mask, else `b`."""
    vals: dict[str, Any] = {}
    for f in fields(ControlState):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "pid":
            vals[f.name] = merge(mask, x, y)
        else:
            vals[f.name] = np.where(mask[:, None] if x.ndim == 2 else mask, x, y)
    return ControlState(**vals)


def control_reset(c: ControlConfig, enc: np.ndarray, pot: np.ndarray) -> ControlState:
    """Twin of sea_control_reset."""
    enc, pot = np.asarray(enc, np.int64), np.asarray(pot, np.int64)
    comp = compression_q16(c.act, enc, pot)
    z = np.zeros_like(enc)
    pbuf = np.repeat(comp[:, None], PRED_AVG_MAX, axis=1)
    return ControlState(
        pid_reset(c.pid, comp, 0), z, z, pot.copy(), z, pbuf, z, enc.copy(), z, z, comp, comp, z, z
    )


def _check(c: ControlConfig, s: ControlState, enc: np.ndarray, pot: np.ndarray, force: np.ndarray):
    """Fault bits of this tick and the updated enc_prev/stuck counters (sea_control_check)."""
    need = max(c.pot_stuck_ticks, 1)
    jump = enc - s.enc_prev
    bits = np.where((jump > c.enc_jump_max) | (-jump > c.enc_jump_max), FAULT_ENC_JUMP, 0)
    lo = np.where(pot <= 0, np.minimum(s.stuck_lo + 1, need), 0)
    hi = np.where(pot >= c.act.pot_max, np.minimum(s.stuck_hi + 1, need), 0)
    bits = bits | np.where(lo >= need, FAULT_POT_STUCK_LOW, 0) | np.where(hi >= need, FAULT_POT_STUCK_HIGH, 0)
    bits = bits | np.where((force < c.force_min) | (force > c.force_max), FAULT_FORCE_RANGE, 0)
    return bits.astype(np.int64), replace(s, enc_prev=enc.copy(), stuck_lo=lo, stuck_hi=hi)


def _pot(c: ControlConfig, s: ControlState, pot: np.ndarray) -> ControlState:
    """Push one pot reading; refresh the average when the block is full (sea_control_pot)."""
    n = max(c.act.pot_avg_ticks, 1)
    total, idx = s.pot_sum + pot, s.pot_idx + 1
    full = idx >= n
    avg = np.where(full, div_rne(sat32(total), n), s.pot_avg)
    return replace(s, pot_sum=np.where(full, 0, total), pot_idx=np.where(full, 0, idx), pot_avg=avg)


def _predict(c: ControlConfig, s: ControlState, pred: np.ndarray) -> ControlState:
    """Push one prediction; desired = mean of the last pred_avg (sea_control_predict)."""
    m = min(max(c.pred_avg, 1), PRED_AVG_MAX)
    buf = s.pred_buf.copy()
    buf[np.arange(buf.shape[0]), s.pred_idx] = pred
    idx = np.where(s.pred_idx + 1 < m, s.pred_idx + 1, 0)
    return replace(s, pred_buf=buf, pred_idx=idx, desired=div_rne(sat32(buf[:, :m].sum(axis=1)), m))


def control_step(
    c: ControlConfig, s: ControlState, enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray
) -> ControlState:
    """Twin of sea_control_step for a batch; the new state's `out` is the command (mV), `fault` the bits."""
    enc, pot = np.asarray(enc, np.int64), np.asarray(pot, np.int64)
    force = np.broadcast_to(np.asarray(force_q16, np.int64), enc.shape)
    latched = s.fault != 0
    bits, checked = _check(c, s, enc, pot, force)
    every = max(c.predict_every, 1)
    n = _pot(c, checked, pot)
    comp = compression_q16(c.act, enc, n.pot_avg)
    due = n.pred_count == 0
    if c.predictor is not None and due.any():
        n = _where(due, _predict(c, n, np.asarray(c.predictor(enc, pot, force), np.int64)), n)
    pid = pid_step(c.pid, s.pid, n.desired, comp)
    count = np.where(n.pred_count + 1 < every, n.pred_count + 1, 0)
    n = replace(n, comp=comp, pred_count=count, pid=pid, out=pid.out)
    safe = replace(checked, fault=s.fault | bits, pid=pid_reset(c.pid, s.comp, 0), out=np.zeros_like(enc))
    return _where(latched, s, _where(bits != 0, safe, n))


def set_desired(s: ControlState, desired_q16: np.ndarray | int) -> ControlState:
    """Twin of sea_control_set_desired."""
    return replace(s, desired=np.broadcast_to(np.asarray(desired_q16, np.int64), s.desired.shape).copy())


def control_run(c: ControlConfig, enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
    """Twin of one actuator's life: control_reset on the first sample, then control_step per sample; the
    motor commands (mV) as an int64 array."""
    s = control_reset(c, enc[:1], pot[:1])
    out = []
    for k in range(len(enc)):
        s = control_step(c, s, enc[k : k + 1], pot[k : k + 1], force_q16[k : k + 1])
        out.append(int(s.out[0]))
    return np.array(out, dtype=np.int64)


def pot_at(share: float, pot_max: int = PAPER.pot_max) -> int:
    """The pot reading at `share` of the ADC's full scale (pot_max + 1 counts), rounded."""
    return round(share * (pot_max + 1))


WALK_POT_START = 0.3662109375  # sensor_walk's first pot reading, share of full scale (1,500 of 12 bits)
WALK_STEPS = (40, 20)  # sensor_walk's largest step per tick: encoder, pot (counts)
WALK_FORCE_SHARES = (0.1, 0.9)  # sensor_walk's desired forces, shares of force_max_n (2-18 N: paper)


def sensor_walk(
    seed: int,
    n: int,
    batch: tuple[int, ...] = (),
    start: tuple[int, int] | None = None,
    steps: tuple[int, int] = WALK_STEPS,
    force_n: tuple[float, float] | None = None,
    hold: int = 100,
    pot_max: int = PAPER.pot_max,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Test sequences for controller ticks, (n, *batch) each: raw enc and pot random walks (steps of at most
    `steps` counts from `start`, by default encoder 400 and the pot at WALK_POT_START of its full scale; pot
    kept off its rails: 1..pot_max - 1) and a desired force (Q16 N) drawn in `force_n` (by default
    WALK_FORCE_SHARES of the paper's force_max_n) and held `hold` ticks."""
    start = (400, pot_at(WALK_POT_START, pot_max)) if start is None else start
    if force_n is None:
        force_n = (WALK_FORCE_SHARES[0] * FORCE_RANGE_N[1], WALK_FORCE_SHARES[1] * FORCE_RANGE_N[1])
    rng = np.random.default_rng(seed)
    enc = start[0] + np.cumsum(rng.integers(-steps[0], steps[0] + 1, (n, *batch)), axis=0)
    pot = np.clip(
        start[1] + np.cumsum(rng.integers(-steps[1], steps[1] + 1, (n, *batch)), axis=0), 1, pot_max - 1
    )
    force = np.repeat(rng.uniform(force_n[0], force_n[1], (n // hold + 1, *batch)), hold, axis=0)[:n]
    return enc, pot, np.vectorize(q16, otypes=[np.int64])(force)


def proven_actuator(path: str | os.PathLike[str] | None) -> Actuator | None:
    """The description at `path` (an --actuator option; None without one), validated (errors name the file
    and field) with its fixed-point formats and PID gains proven for the C (a design the generated C cannot
    hold is refused when it is given, not at export after the data and the training; exit 2)."""
    from seagen.actuator import ActuatorError, load_actuator

    if not path:
        return None
    act = load_actuator(path)
    try:
        ControlConfig.for_act(act_q(act))  # act_q's refusals name the file
    except GainRangeError as e:  # worded as act_q's refusals: the file, the name, the field
        raise ActuatorError(
            f"{act.source} ('{act.name}'): {e.why}; the generated C could not run this design"
        ) from None
    except ActuatorError as e:
        raise ActuatorError(f"{e}; the generated C could not run this design") from None
    return act
