"""One feature pipeline per actuator, shared by its calibration model and its controller's predictor
(NAME_step_features, NAME_controller_init_shared), gives the same integers as each model running its own
pipeline (NAME_step, NAME_controller_init) and as the Python twin of the shared form, on the host (cffi)."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.codegen.controller import controller_files, shipped_config
from seagen.codegen.runtime import runtime_sources
from seagen.control.gentwin import StepTwin
from seagen.defaults import GENERATED
from seagen.reference import numpy_ref
from seagen.runtime import features as F
from seagen.runtime.actq import act_q_of
from seagen.runtime.control import ControlConfig, control_reset, control_step, q16, sensor_walk
from seagen.setups.shipped import export as default_ir
from seagen.toolchain.controller import generated_sources
from seagen.toolchain.host import build

PAIRS = [("cal_mlp", "ctl_mlp"), ("cal_mlp", "ctl_sf"), ("cal_sf", "ctl_sf"), ("cal_sf", "ctl_mlp")]
STATE = ("out", "desired", "comp", "pot_avg", "fault")
N_SEA, TICKS = 3, 160

HARNESS_H = """
typedef struct {{ {cal}_state_t cal; {ctl}_controller_t ctl; }} sep_{cal}_{ctl}_t;
typedef struct {{ sea_features_state feat; sea_features_out f; {ctl}_controller_t ctl; }} shr_{cal}_{ctl}_t;
void sep_{cal}_{ctl}_init(sep_{cal}_{ctl}_t *a, int32_t e, int32_t p);
int32_t sep_{cal}_{ctl}_tick(sep_{cal}_{ctl}_t *a, int32_t e, int32_t p, int32_t f, int16_t *y, int32_t *st);
void shr_{cal}_{ctl}_init(shr_{cal}_{ctl}_t *a, int32_t e, int32_t p);
int32_t shr_{cal}_{ctl}_tick(shr_{cal}_{ctl}_t *a, int32_t e, int32_t p, int32_t f, int16_t *y, int32_t *st);
"""
HARNESS_C = """
static void st_{cal}_{ctl}(const sea_control_state *s, int32_t *st)
{{
    st[0] = s->out; st[1] = s->desired; st[2] = s->comp; st[3] = s->pot_avg; st[4] = s->fault;
}}
void sep_{cal}_{ctl}_init(sep_{cal}_{ctl}_t *a, int32_t e, int32_t p)
{{
    {cal}_reset(&a->cal);
    {ctl}_controller_init(&a->ctl, e, p);
}}
int32_t sep_{cal}_{ctl}_tick(sep_{cal}_{ctl}_t *a, int32_t e, int32_t p, int32_t f, int16_t *y, int32_t *st)
{{
    int32_t out;
    *y = {cal}_step(&a->cal, e, p);
    out = {ctl}_controller_tick(&a->ctl, e, p, f);
    st_{cal}_{ctl}(&a->ctl.state, st);
    return out;
}}
void shr_{cal}_{ctl}_init(shr_{cal}_{ctl}_t *a, int32_t e, int32_t p)
{{
    sea_features_reset(&a->feat);
    {ctl}_controller_init_shared(&a->ctl, e, p, &a->f);
}}
int32_t shr_{cal}_{ctl}_tick(shr_{cal}_{ctl}_t *a, int32_t e, int32_t p, int32_t f, int16_t *y, int32_t *st)
{{
    int32_t out;
    sea_features_step(&a->feat, {CAL}_ACT, e, p, &a->f);
    *y = {cal}_step_features(&a->f);
    out = {ctl}_controller_tick(&a->ctl, e, p, f);
    st_{cal}_{ctl}(&a->ctl.state, st);
    return out;
}}
"""


@pytest.fixture(scope="module")
def lib():
    """The four default models with both controllers, and a harness per (calibration, control) pair that
    runs them with their own pipelines (sep_) and with one shared pipeline (shr_), built with cffi."""
    files = runtime_sources("sea_fixed.h", "sea_fixed.c")
    for p in ("cal_mlp", "cal_sf", "ctl_mlp", "ctl_sf"):
        files |= generated_sources(p, GENERATED)
    for p in ("ctl_mlp", "ctl_sf"):
        files |= controller_files(p, default_ir(p).qmodel)
    includes = "".join(f'#include "{p}.h"\n' for p in ("cal_mlp", "cal_sf"))
    includes += "".join(f'#include "{p}_controller.h"\n' for p in ("ctl_mlp", "ctl_sf"))
    h = "".join(HARNESS_H.format(cal=c, ctl=k) for c, k in PAIRS)
    files["pairs.h"] = f"#ifndef PAIRS_H\n#define PAIRS_H\n{includes}{h}#endif\n"
    files["pairs.c"] = '#include "pairs.h"\n' + "".join(
        HARNESS_C.format(cal=c, ctl=k, CAL=c.upper()) for c, k in PAIRS
    )
    cdef = "".join(
        f"typedef struct {{ ...; }} sep_{c}_{k}_t;\ntypedef struct {{ ...; }} shr_{c}_{k}_t;\n"
        + "\n".join(line for line in HARNESS_H.format(cal=c, ctl=k).splitlines() if "(" in line)
        for c, k in PAIRS
    )
    mod = build(cdef, files, name="shared_features")
    return mod.lib, mod.ffi


def _sequence(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random walks with faults injected: a desired force out of range, an encoder jump, the pot at a rail
    (each latches its actuator's safe state; the test then restarts it)."""
    enc, pot, force = sensor_walk(seed, TICKS, (N_SEA,), start=(300, 1200), force_n=(1.0, 15.0), hold=40)
    force[50, 0] = q16(25.0)
    enc[80:, 1] += 5000
    pot[110:125, 2] = 0
    return enc, pot, force


def _run_c(lib, ffi, kind: str, cal: str, ctl: str, enc, pot, force) -> dict[str, np.ndarray]:
    """One actuator object per column; init at tick 0 and again on the tick after any latched fault."""
    init, tick = getattr(lib, f"{kind}_{cal}_{ctl}_init"), getattr(lib, f"{kind}_{cal}_{ctl}_tick")
    objs = [ffi.new(f"{kind}_{cal}_{ctl}_t *") for _ in range(N_SEA)]
    est, st = ffi.new("int16_t *"), ffi.new("int32_t[5]")
    rec = {f: np.zeros((TICKS, N_SEA), np.int64) for f in ("est", *STATE)}
    for i, a in enumerate(objs):
        init(a, int(enc[0, i]), int(pot[0, i]))
    for k in range(TICKS):
        for i, a in enumerate(objs):
            if k and rec["fault"][k - 1, i]:
                init(a, int(enc[k, i]), int(pot[k, i]))
            tick(a, int(enc[k, i]), int(pot[k, i]), int(force[k, i]), est, st)
            rec["est"][k, i] = est[0]
            for j, f in enumerate(STATE):
                rec[f][k, i] = st[j]
    return rec


def _run_twin(cal: str, ctl: str, enc, pot, force) -> dict[str, np.ndarray]:
    """The Python twin of the shared form: one Pipeline per actuator, read by the calibration model and by
    the predictor (StepTwin.shared); restarted like the C."""
    a, cal_qm = act_q_of(), default_ir(cal).qmodel
    base = shipped_config(default_ir(ctl).qmodel)
    rec = {f: np.zeros((TICKS, N_SEA), np.int64) for f in ("est", *STATE)}
    for i in range(N_SEA):
        col = slice(i, i + 1)
        for k in range(TICKS):
            if k == 0 or rec["fault"][k - 1, i]:
                pipe = F.Pipeline(a)
                c = ControlConfig(
                    **{**base.__dict__, "predictor": StepTwin(ctl, default_ir(ctl).qmodel).shared(pipe)}
                )
                s = control_reset(c, enc[k, col], pot[k, col])
            b, d, dd = pipe.step(enc[k, col], pot[k, col])
            rec["est"][k, i] = numpy_ref.infer(cal_qm, F.inputs(a, cal_qm.inputs, b, d, dd, None))[0]
            s = control_step(c, s, enc[k, col], pot[k, col], force[k, col])
            for f in STATE:
                rec[f][k, i] = getattr(s, f)[0]
    return rec


@pytest.mark.parametrize(("cal", "ctl"), PAIRS)
def test_shared_equals_own_pipelines_and_twin(lib, cal, ctl):
    """Force estimates, commands and controller state of every tick: shared pipeline == each model with its
    own pipeline == the shared form's Python twin (np.array_equal), through faults and restarts; the pairs
    use different feature sets (MLP: pot, enc, compression and their differences; SF: angle, compression)."""
    c, ffi = lib
    enc, pot, force = _sequence(3)
    sep = _run_c(c, ffi, "sep", cal, ctl, enc, pot, force)
    shr = _run_c(c, ffi, "shr", cal, ctl, enc, pot, force)
    twin = _run_twin(cal, ctl, enc, pot, force)
    for f in sep:
        assert np.array_equal(shr[f], sep[f]), f"{f}: shared differs from own pipelines"
        assert np.array_equal(shr[f], twin[f]), f"{f}: shared differs from its twin"
    assert (sep["fault"] != 0).any(axis=0).all(), "every actuator should have faulted once"
    assert np.abs(sep["out"]).max() > 0 and np.unique(sep["est"]).size > 10


def test_predictor_called_every_tick_only():
    """NAME_controller_init_shared exists only where the predictor runs every tick: at predict_every > 1
    a pipeline of its own samples fewer ticks than the actuator's, so the shared one would differ."""
    from dataclasses import replace

    qm = default_ir("ctl_sf").qmodel
    every_tick = controller_files("ctl_sf", qm)
    slow = controller_files("ctl_sf", qm, replace(shipped_config(qm), predict_every=10))
    assert "ctl_sf_controller_init_shared" in every_tick["ctl_sf_controller.h"]
    assert "init_shared" not in slow["ctl_sf_controller.h"] + slow["ctl_sf_controller.c"]
