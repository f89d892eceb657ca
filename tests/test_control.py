"""The two-level controller in C (c_runtime/sea_control.c) equals its Python twin tick for tick; faults."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.control.loop import PyController
from seagen.runtime import control as ct
from seagen.runtime import fixed as P
from seagen.runtime.control import ControlConfig, KinParams, predict_kinematic
from seagen.toolchain.controller import CController, build_control, kin_ctx

FIELDS = ("desired", "comp", "pot_avg", "fault", "stuck_lo", "stuck_hi", "pred_count", "pred_idx")


@pytest.fixture(scope="module")
def mod():
    """The controller runtime built with the strict flags."""
    return build_control()


def _pair(mod, every: int, with_pred: bool = True, avg: int = 1):
    """The C and Python controllers for the kinematic predictor called every `every` ticks."""
    k = KinParams()
    pred = predict_kinematic(k) if with_pred else None
    c = ControlConfig(predictor=pred, predict_every=every, pred_avg=avg)
    cc = CController(mod, c, "sea_predict_kinematic" if with_pred else None, kin_ctx(mod, k))
    return cc, PyController(c)


def _inputs(kind: str, n: int, b: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """(enc, pot, force_q16) sequences (ticks x batch) of one kind."""
    enc = np.cumsum(rng.integers(-60, 61, (n, b)), axis=0)
    pot = np.clip(1500 + np.cumsum(rng.integers(-15, 16, (n, b)), axis=0), 0, 4095)
    force = np.repeat(rng.integers(0, P.INT32_MAX // 3276, (n // 25 + 1, b)), 25, axis=0)[:n] % (20 << 16)
    if kind == "faults":  # rare rail readings, encoder jumps, out-of-range forces
        pot = np.where(rng.random((n, b)) < 0.3, rng.choice([0, 4095], (n, b)), pot)
        enc = enc + np.where(rng.random((n, b)) < 0.003, rng.integers(-500, 500, (n, b)), 0)
        force = np.where(rng.random((n, b)) < 0.002, rng.integers(-(2**31), 2**31, (n, b)), force)
    elif kind == "rails":  # pot stuck for runs shorter and longer than the fault threshold
        pot = np.where((np.arange(n)[:, None] // 7) % 3 == 0, 4095, pot)
        pot[300:330, 0] = 0
    return enc, pot, force


@pytest.mark.parametrize("kind", ["normal", "faults", "rails"])
@pytest.mark.parametrize("every,avg", [(1, 1), (10, 1), (0, 1), (1, 10), (3, 4), (1, 0), (2, 99)])
def test_control_c_equals_twin(mod, kind, every, avg):
    """sea_control_step == control_step (command and every state field) on each tick of 600-tick runs,
    for predictor periods and prediction averages (pred_avg clamped to 1..10) of every kind."""
    rng = np.random.default_rng(every * 10 + avg + len(kind))
    enc, pot, force = _inputs(kind, 600, 6, rng)
    cc, py = _pair(mod, every, avg=avg)
    cc.reset(enc[0], pot[0])
    py.reset(enc[0], pot[0])
    for k in range(enc.shape[0]):
        oc, op = cc.step(enc[k], pot[k], force[k]), py.step(enc[k], pot[k], force[k])
        if k % 97 == 50:  # bumpless recovery from faults
            cc.reset(enc[k], pot[k])
            py.reset(enc[k], pot[k])
        for name, a, b in [("out", oc, op)] + [(f, cc.field(f), py.field(f)) for f in FIELDS]:
            assert np.array_equal(a, b), (
                f"{name} tick {k} enc={enc[k]} pot={pot[k]} force={force[k]}: {a} vs {b}"
            )


def test_external_desired(mod):
    """With no predictor, sea_control_set_desired drives the PID identically in C and Python."""
    rng = np.random.default_rng(3)
    enc, pot, force = _inputs("normal", 300, 4, rng)
    cc, py = _pair(mod, 1, with_pred=False)
    cc.reset(enc[0], pot[0])
    py.reset(enc[0], pot[0])
    for k in range(300):
        if k % 10 == 3:
            d = rng.integers(-(2**20), 2**20, 4)
            cc.set_desired(d)
            py.set_desired(d)
        assert np.array_equal(cc.step(enc[k], pot[k], force[k]), py.step(enc[k], pot[k], force[k])), k


@pytest.mark.parametrize("num", [0, 5, 15, 25, -5, -15, 40950, -(2**31), 2**31 - 1, 7, -7])
@pytest.mark.parametrize("den", [1, 2, 3, 10, 4095, 0, -3])
def test_div_rne(mod, num, den):
    """sea_div_rne_s32 == div_rne, ties to even, floor-consistent for negatives, 0 for den <= 0."""
    assert mod.lib.sea_div_rne_s32(num, den) == int(P.div_rne(num, den))


def test_kinematic_predictor(mod):
    """sea_predict_kinematic == its twin over forces incl. int32 extremes."""
    k = KinParams()
    ctx = kin_ctx(mod, k)
    f = np.r_[
        np.random.default_rng(1).integers(-(2**31), 2**31, 3000), [P.INT32_MIN, P.INT32_MAX, 0, 1 << 16]
    ]
    got = np.array([mod.lib.sea_predict_kinematic(ctx, 0, 0, int(x)) for x in f])
    assert np.array_equal(got, predict_kinematic(k)(f, f, f))


FAULTS = [  # (name, tick at which the bad input starts, enc offset, pot override, force N, expected bits)
    ("pot_stuck_low", 20, 0, 0, 5.0, ct.FAULT_POT_STUCK_LOW),
    ("pot_stuck_high", 20, 0, 4095, 5.0, ct.FAULT_POT_STUCK_HIGH),
    ("enc_jump", 20, ct.ENC_JUMP_MAX + 1, None, 5.0, ct.FAULT_ENC_JUMP),
    ("force_range_high", 20, 0, None, 20.5, ct.FAULT_FORCE_RANGE),
    ("force_range_negative", 20, 0, None, -1.0, ct.FAULT_FORCE_RANGE),
]


@pytest.mark.parametrize("name,start,djump,pot_bad,force_n,bits", FAULTS, ids=[f[0] for f in FAULTS])
def test_fault_safe_state(mod, name, start, djump, pot_bad, force_n, bits):
    """A fault latches its code at the expected tick, the motor is 0 mV and the integrator 0 until reset."""
    for impl in _pair(mod, 1):
        impl.reset(np.array([0]), np.array([1500]))
        want_tick = start + (ct.POT_STUCK_TICKS - 1 if pot_bad is not None else 0)
        for k in range(60):
            bad = k >= start
            enc = np.array([djump if bad else 0])
            pot = np.array([pot_bad if bad and pot_bad is not None else 1500])
            f = ct.q16(force_n if bad else 5.0)
            out = impl.step(enc, pot, np.array([f]))
            assert impl.field("fault")[0] == (bits if k >= want_tick else 0), (type(impl).__name__, k)
            if k >= want_tick:
                assert out[0] == 0
        integ = impl.states[0].pid.integ if isinstance(impl, CController) else int(impl.s.pid.integ[0])
        assert integ == 0
