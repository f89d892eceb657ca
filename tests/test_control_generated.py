"""Generated control predictors (generated/ctl_sf, ctl_mlp) in the controller: C == integer twins, exactly."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.control.gentwin import StepTwin
from seagen.control.loop import run_closed_loop
from seagen.defaults import GENERATED
from seagen.reference import numpy_ref
from seagen.runtime import control as ct
from seagen.runtime import nn as K
from seagen.runtime.actq import act_q_of
from seagen.runtime.control import ControlConfig
from seagen.runtime.features import step_features
from seagen.setups.shipped import export, generated_mcu
from seagen.toolchain.controller import build_control, generated_cdef, generated_ctx, generated_sources

PREFIXES = ["ctl_sf", "ctl_mlp"]
ANGLES = np.array([8.0, 15.0, 24.0])


def _seq(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random raw (enc, pot, force_q16) sequences (n ticks), including rails and out-of-box forces."""
    rng = np.random.default_rng(seed)
    enc = np.cumsum(rng.integers(-60, 61, n))
    pot = np.clip(1500 + np.cumsum(rng.integers(-40, 41, n)), 0, 4095)
    force = rng.integers(-(2 << 16), 25 << 16, n)
    return enc, pot, force


@pytest.mark.parametrize("prefix", PREFIXES)
def test_step_twin_equals_c_and_sequence_reference(prefix):
    """StepTwin (one call per tick) == NAME_predict_q16 in C == step_features + numpy infer, scaled to Q16."""
    mod = build_control(generated_cdef(prefix, GENERATED), generated_sources(prefix, GENERATED))
    ctx = generated_ctx(prefix)(mod)
    enc, pot, force = _seq(3000, len(prefix))
    fn = getattr(mod.lib, f"{prefix}_predict_q16")
    c = np.array([fn(ctx, int(e), int(p), int(f)) for e, p, f in zip(enc, pot, force, strict=True)])
    tw = StepTwin(prefix, export(prefix).qmodel)
    py = np.array([int(tw(enc[k : k + 1], pot[k : k + 1], force[k : k + 1])[0]) for k in range(len(enc))])
    qm = export(prefix).qmodel
    ext = K.to_s16(force, 16, qm.inputs[0].frac)[:, None]
    x = step_features(qm, act_q_of(), enc, pot, np.zeros(len(enc), int), ext)
    ref = numpy_ref.infer(qm, x) * (1 << (16 - qm.out_frac))
    assert np.array_equal(c, py), int(np.argmax(c != py))
    assert np.array_equal(c, ref), int(np.argmax(c != ref))


@pytest.mark.parametrize("prefix,avg", [("ctl_sf", 1), ("ctl_mlp", 10)])
def test_closed_loop_10s_c_equals_twin(prefix, avg):
    """10 s closed loop, C controller + generated C predictor vs Python twins: every record equal exactly."""
    cfg = ControlConfig(pred_avg=avg)
    runs = [
        run_closed_loop(generated_mcu(prefix), 10.0, ANGLES, impl=i, duration_s=10.0, seed=3, control_cfg=cfg)
        for i in ("c", "py")
    ]
    for key in runs[0]:
        a, b = runs[0][key], runs[1][key]
        if not np.array_equal(a, b):
            k = int(np.argmax((a != b).reshape(a.shape[0], -1).any(axis=1)))
            pytest.fail(f"{key} differs first at tick {k}: C {a[k]} vs Python {b[k]}")
    assert (runs[0]["true_force_n"][-1] > 8.0).all()


def _hook(kind: str):
    """Sensor fault from tick 100: pot stuck at a rail, or an encoder jump."""
    if kind == "enc_jump":
        return lambda k, enc, pot: (enc + 1000 if k >= 100 else enc, pot)
    value = 0 if kind == "pot_stuck_low" else 4095
    return lambda k, enc, pot: (enc, np.full_like(pot, value) if k >= 100 else pot)


FAULTS = [  # (name, sensor hook kind, force at tick >= 100, fault bits, first faulted tick)
    ("pot_stuck_low", "pot_stuck_low", 10.0, ct.FAULT_POT_STUCK_LOW, 100 + ct.POT_STUCK_TICKS - 1),
    ("pot_stuck_high", "pot_stuck_high", 10.0, ct.FAULT_POT_STUCK_HIGH, 100 + ct.POT_STUCK_TICKS - 1),
    ("enc_jump", "enc_jump", 10.0, ct.FAULT_ENC_JUMP, 100),
    ("force_range", None, 25.0, ct.FAULT_FORCE_RANGE, 100),
]


@pytest.mark.parametrize("name,kind,late_n,bits,tick", FAULTS, ids=[f[0] for f in FAULTS])
def test_fault_in_loop_generated_mlp(name, kind, late_n, bits, tick):
    """With ctl_mlp in C, each fault latches at its tick, motor off after; C and twin records agree."""
    pred = generated_mcu("ctl_mlp")
    hook = _hook(kind) if kind else None
    runs = [
        run_closed_loop(
            pred,
            lambda k: 10.0 if k < 100 else late_n,
            ANGLES,
            impl=i,
            duration_s=1.5,
            sensor_hook=hook,
            control_cfg=ControlConfig(pred_avg=10),
        )
        for i in ("c", "py")
    ]
    r = runs[0]
    assert (r["fault"][:tick] == 0).all() and (r["fault"][tick:] == bits).all()
    assert (r["out_mv"][tick:] == 0).all() and r["out_mv"][:tick].any()
    for key in ("out_mv", "fault", "desired", "comp", "motor_mm"):
        assert np.array_equal(r[key], runs[1][key]), key
