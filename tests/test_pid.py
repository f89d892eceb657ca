"""The fixed-point PID in C (c_runtime/sea_pid.c) equals its Python twin (seagen/runtime/pid.py) exactly."""

from __future__ import annotations

import subprocess
import zlib

import numpy as np
import pytest

from seagen.codegen.runtime import cdef_of, runtime_sources
from seagen.runtime.pid import (
    DEFAULT_PID,
    DEFAULT_PID_SI,
    MOTOR_MAX_MV,
    TICK_S,
    PidParams,
    pid_reset,
    pid_step,
)
from seagen.toolchain.host import build, build_exe

# Harness: run n ticks; where reset[k] != 0 the PID is reset (meas[k], rout[k]) before ticking.
HARNESS_C = r"""
#include "sea_pid.h"
void pid_run(const sea_pid_params *p, int32_t n, const int32_t *sp, const int32_t *meas, const int32_t *reset,
             const int32_t *rout, int32_t *out, int64_t *integ, int32_t *dfilt)
{
    sea_pid_state s;
    int32_t k;
    sea_pid_reset(p, &s, meas[0], 0);
    for (k = 0; k < n; k++) {
        if (reset[k] != 0) {
            sea_pid_reset(p, &s, meas[k], rout[k]);
        }
        out[k] = sea_pid_step(p, &s, sp[k], meas[k]);
        integ[k] = s.integ;
        dfilt[k] = s.d_filt;
    }
}
"""
MAIN_C = r"""
#include <stdio.h>
#include "sea_pid.h"
void pid_run(const sea_pid_params *p, int32_t n, const int32_t *sp, const int32_t *meas, const int32_t *reset,
             const int32_t *rout, int32_t *out, int64_t *integ, int32_t *dfilt);
static int32_t sp[4096], meas[4096], rst[4096], dfilt[4096];
static int64_t integ[4096];
static int32_t rout[4096], out[4096];
int main(void)
{
    sea_pid_params p;
    long a, b, c, d;
    int32_t n = 0, k;
    if (scanf("%d %d %d %d %d %d %d", &p.kp, &p.ki, &p.kd, &p.d_alpha, &p.margin, &p.out_min,
              &p.out_max) != 7)
        return 2;
    while (n < 4096 && scanf("%ld %ld %ld %ld", &a, &b, &c, &d) == 4) {
        sp[n] = (int32_t)a; meas[n] = (int32_t)b; rst[n] = (int32_t)c; rout[n] = (int32_t)d; n++;
    }
    pid_run(&p, n, sp, meas, rst, rout, out, integ, dfilt);
    for (k = 0; k < n; k++)
        printf("%d %lld %d\n", out[k], (long long)integ[k], dfilt[k]);
    return 0;
}
"""
HARNESS_CDEF = """
void pid_run(const sea_pid_params *p, int32_t n, const int32_t *sp, const int32_t *meas, const int32_t *reset,
             const int32_t *rout, int32_t *out, int64_t *integ, int32_t *dfilt);
"""
SOURCES = ("sea_fixed.h", "sea_fixed.c", "sea_fixed_ctrl.c", "sea_pid.h", "sea_pid.c")
CDEF = cdef_of(*runtime_sources("sea_fixed.h", "sea_pid.h").values()) + "\n"
I32 = (-(2**31), 2**31 - 1)


@pytest.fixture(scope="module")
def c():
    """The PID and the harness built with the strict flags."""
    return build(CDEF + HARNESS_CDEF, {**runtime_sources(*SOURCES), "pid_harness.c": HARNESS_C}, name="pid")


def _seq(kind: str, n: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """(setpoint, meas, reset, reset_out) of one kind of sequence, int64."""
    sp = np.cumsum(rng.integers(-3000, 3000, n)) + 200_000
    meas = sp + rng.integers(-20_000, 20_000, n)
    if kind == "saturated":
        meas = sp + rng.choice([-1, 1], n) * rng.integers(300_000, 2_000_000, n)
    elif kind == "margin":  # errors straddling +-0.1 mm (6554 Q16)
        meas = sp + rng.choice([-1, 1], n) * (6554 + rng.integers(-3, 4, n))
    elif kind == "extreme":
        sp, meas = rng.choice(I32, n), rng.integers(*I32, n, endpoint=True)
    elif kind == "walk":
        meas = np.cumsum(rng.integers(-5000, 5000, n))
        sp = np.repeat(rng.integers(-300_000, 300_000, n // 50 + 1), 50)[:n]
    reset = (rng.random(n) < (0.02 if kind in ("resets", "walk") else 0.0)).astype(np.int64)
    rout = rng.integers(-20_000, 20_000, n)
    if kind == "extreme":  # bumpless restarts anywhere in the int32 command range
        rout = rng.integers(*I32, n, endpoint=True)
    return sp, meas, reset, rout


def _twin(p: PidParams, sp, meas, reset, rout) -> tuple[np.ndarray, ...]:
    """Python twin over a batch of sequences (columns), same reset protocol as the harness."""
    s = pid_reset(p, meas[0], 0)
    rows = []
    for k in range(sp.shape[0]):
        r = reset[k] != 0
        if r.any():
            s2 = pid_reset(p, meas[k], rout[k])
            s = type(s)(
                *(np.where(r, getattr(s2, f), getattr(s, f)) for f in ("integ", "d_filt", "meas_prev", "out"))
            )
        s = pid_step(p, s, sp[k], meas[k])
        rows.append((s.out, s.integ, s.d_filt))
    return tuple(np.array([r[i] for r in rows]) for i in range(3))


def _c_run(c, p: PidParams, sp, meas, reset, rout) -> tuple[np.ndarray, ...]:
    """The C harness over one sequence."""
    ffi, n = c.ffi, len(sp)
    cp = ffi.new("sea_pid_params *", p.as_tuple())
    arr = [ffi.new("int32_t[]", [int(x) for x in a]) for a in (sp, meas, reset)]
    ro = ffi.new("int32_t[]", [int(x) for x in rout])
    out, integ, dfilt = ffi.new("int32_t[]", n), ffi.new("int64_t[]", n), ffi.new("int32_t[]", n)
    c.lib.pid_run(cp, n, *arr, ro, out, integ, dfilt)
    return tuple(np.array(list(a), dtype=np.int64) for a in (out, integ, dfilt))


PAPER_RANGE = {"out_min": -MOTOR_MAX_MV, "out_max": MOTOR_MAX_MV}  # the paper's 12 V supply, in mV
PAPER_SI = {"limit_v": MOTOR_MAX_MV / 1000, "max_mv": MOTOR_MAX_MV, "tick_s": TICK_S}  # and its 100 Hz tick
PARAMS = {
    "default": DEFAULT_PID,
    "stiff": PidParams(kp=2**28, ki=2**24, kd=2**26, d_alpha=65536, margin=6554, **PAPER_RANGE),
    "no_margin_neg_gains": PidParams(
        kp=-(2**20), ki=-3000, kd=-(2**18), d_alpha=1000, margin=-5, **PAPER_RANGE
    ),
    "extreme": PidParams(
        kp=2**31 - 1, ki=-(2**31), kd=2**31 - 1, d_alpha=2**31 - 1, margin=2**31 - 1, **PAPER_RANGE
    ),
    "narrow_range": PidParams(kp=50_000, ki=900, kd=4000, d_alpha=20_000, margin=0, out_min=-3, out_max=700),
    "alpha_negative": PidParams(
        kp=90_000, ki=77, kd=123_456, d_alpha=-7, margin=100, out_min=-32768, out_max=32767
    ),
    # a 48 V motor, and the whole int32 command range (the command is int32 mV, the integrator Q16 int64)
    "supply_48v": PidParams(
        kp=2**22, ki=2**18, kd=2**20, d_alpha=40_000, margin=0, out_min=-48000, out_max=48000
    ),
    "int32_range": PidParams(
        kp=2**31 - 1, ki=2**31 - 1, kd=-(2**31), d_alpha=65536, margin=0, out_min=-(2**31), out_max=2**31 - 1
    ),
}
KINDS = ("unsaturated", "saturated", "margin", "resets", "walk", "extreme")


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("pname", sorted(PARAMS))
def test_pid_c_equals_twin(c, pname, kind):
    """sea_pid_step == pid_step (out, integrator, filtered rate) on every tick of 8 random 600-tick runs."""
    p, rng = PARAMS[pname], np.random.default_rng(zlib.crc32(f"{pname}/{kind}".encode()))
    seqs = [_seq(kind, 600, rng) for _ in range(8)]
    want = _twin(p, *(np.stack([s[i] for s in seqs], axis=1) for i in range(4)))
    for j, s in enumerate(seqs):
        got = _c_run(c, p, *s)
        for name, g, w in zip(("out", "integ", "d_filt"), got, want, strict=True):
            if not np.array_equal(g, w[:, j]):
                k = int(np.argmax(g != w[:, j]))
                pytest.fail(
                    f"{name} tick {k}, input sp={s[0][k]} meas={s[1][k]} reset={s[2][k]}: "
                    f"C {g[k]} py {w[k, j]}"
                )


@pytest.mark.parametrize(
    "meas,out", [(0, 0), (123_456, 3000), (-(2**31), -12000), (2**31 - 1, 12000), (7, 20_000)]
)
def test_bumpless_reset(c, meas, out):
    """After reset(meas, out), a tick inside the margin with unchanged meas returns clamp(out) exactly."""
    p = DEFAULT_PID
    sp = meas + (100 if meas < 0 else -100)
    got = _c_run(c, p, np.array([sp]), np.array([meas]), np.array([1]), np.array([out]))
    want = min(max(out, p.out_min), p.out_max)
    assert got[0][0] == want and _twin(p, *(np.array([[x]]) for x in (sp, meas, 1, out)))[0][0, 0] == want


@pytest.mark.parametrize("pid", ["paper", "default"])
@pytest.mark.parametrize("err", [-1.0, -1e-5, 0.0, 1e-5, 1.0])  # x the margin (paper: 0.1 mm = 6554 Q16)
def test_margin_holds_integrator(c, err, pid):
    """Inside the margin the integrator is held and P is zero: out = integrator with a still measurement."""
    p = PidParams.from_si(24.0, 6.0, 0.1, 0.5, margin_mm=0.1, **PAPER_SI) if pid == "paper" else DEFAULT_PID
    err = int(np.sign(err)) if abs(err) < 1 and err else int(err * p.margin)
    n = 20
    got = _c_run(
        c, p, np.full(n, 50_000 + err), np.full(n, 50_000), np.r_[1, np.zeros(n - 1, int)], np.full(n, 777)
    )
    assert np.array_equal(got[0], np.full(n, 777)) and np.array_equal(got[1], np.full(n, 777 << 16))


@pytest.mark.parametrize("sign", [1, -1])
def test_anti_windup(c, sign):
    """Saturated for 500 ticks, the integrator stays within range and the output leaves saturation the
    tick the error reverses (no wound-up integral to unwind)."""
    p = PidParams.from_si(2.0, 50.0, 0.0, 1.0, margin_mm=DEFAULT_PID_SI["margin_mm"], **PAPER_SI)
    n = 520
    err = np.r_[np.full(500, sign * 2**22), np.full(20, -sign * 2**17)]
    out, integ, _ = _c_run(c, p, err, np.zeros(n, int), np.zeros(n, int), np.zeros(n, int))
    assert np.all(np.abs(integ) <= 12000 << 16) and out[499] == sign * 12000
    assert sign * out[500] < 12000


def test_sanitized_harness_matches_twin():
    """The PID under UBSan+ASan, driven through stdin by the same sequences, prints the twin's integers."""
    exe = build_exe(
        {**runtime_sources(*SOURCES), "pid_harness.c": HARNESS_C, "main.c": MAIN_C}, name="pid_san"
    )
    rng = np.random.default_rng(5)
    for pname in ("extreme", "default", "narrow_range"):
        p = PARAMS[pname]
        for kind in ("extreme", "saturated", "resets"):
            s = _seq(kind, 400, rng)
            text = (
                " ".join(map(str, p.as_tuple()))
                + "\n"
                + "\n".join(" ".join(map(str, r)) for r in zip(*s, strict=True))
            )
            res = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=False)
            assert res.returncode == 0 and not res.stderr, res.stderr
            got = np.loadtxt(res.stdout.splitlines(), dtype=np.int64, ndmin=2)
            want = np.stack([w[:, 0] for w in _twin(p, *(np.asarray(x)[:, None] for x in s))], axis=1)
            assert np.array_equal(got, want), (
                f"{pname}/{kind}: first mismatch row {int(np.argmax((got != want).any(1)))}"
            )
