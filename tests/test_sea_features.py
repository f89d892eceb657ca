"""The feature pipeline in C (c_runtime/sea_features.c) equals its Python twin (seagen.runtime.features)."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.codegen.runtime import cdef_of, runtime_sources
from seagen.data.features import derive
from seagen.data.schema import load_split
from seagen.runtime import features as F
from seagen.runtime.actq import act_q_of
from seagen.toolchain.actc import CAct
from seagen.toolchain.host import build

HEADERS = ("sea_fixed.h", "sea_nn.h", "sea_features.h")
SOURCES = (*HEADERS, "sea_fixed.c", "sea_fixed_ctrl.c", "sea_nn.c", "sea_features.c")
I32 = (-(2**31), 2**31 - 1)


@pytest.fixture(scope="module")
def c():
    """sea_fixed, sea_nn and sea_features built with the strict flags; declarations from the headers."""
    return build(cdef_of(*runtime_sources(*HEADERS).values()), runtime_sources(*SOURCES), name="features")


def _run_c(c, a, enc, pot, reset) -> dict[str, np.ndarray]:
    """sea_features_step per sample (sea_features_reset where reset), every output field recorded."""
    ffi, lib = c.ffi, c.lib
    ct = CAct(ffi, a)
    s, f = ffi.new("sea_features_state *"), ffi.new("sea_features_out *")
    out = {k: np.zeros((F.N_BASE, len(enc)), np.int64) for k in ("b", "d", "dd")}
    out["angle"] = np.zeros(len(enc), np.int64)
    lib.sea_features_reset(s)
    for k, (e, p, r) in enumerate(zip(enc, pot, reset, strict=True)):
        if r:
            lib.sea_features_reset(s)
        lib.sea_features_step(s, ct.ptr, int(e), int(p), f)
        out["b"][:, k] = list(f.b)
        out["d"][:, k] = [lib.sea_features_value(f, F.D, i) for i in range(F.N_BASE)]
        out["dd"][:, k] = [lib.sea_features_value(f, F.DD, i) for i in range(F.N_BASE)]
        out["angle"][k] = lib.sea_features_value(f, F.ANGLE, 0)
    return out


def _check(c, enc, pot, trial, a=None) -> None:
    """C per sample == Python over whole trials (over_trials), for actuator `a` (the paper's when None)."""
    a = a or act_q_of()
    trial = np.asarray(trial)
    got = _run_c(c, a, enc, pot, np.r_[True, trial[1:] != trial[:-1]])
    b = F.bases_q(a, enc, pot)
    d, dd = F.over_trials(b, trial)
    want = {"b": b, "d": d, "dd": dd, "angle": F.angle_q24(a, pot)}
    for k, w in want.items():
        bad = np.flatnonzero((got[k] != w).reshape(-1, len(enc)).any(axis=0))
        assert bad.size == 0, f"{k} differs first at sample {bad[0]}: enc {enc[bad[0]]}, pot {pot[bad[0]]}"


def test_recorded_trials(c, data_dir):
    """On the seed-0 test and validation trials (raw enc/pot, reset at every trial start) C == twin."""
    for split in ("test", "validation"):
        df = load_split(data_dir, split)
        _check(c, df.enc.to_numpy(), df.pot.to_numpy(), df.trial.to_numpy())


def test_edge_values_and_resets(c):
    """int32 extremes of enc and pot (pot beyond 0..4095), jumps whose differences overflow int32, and
    trials of length 1, 2 and 3: C == twin (d and dd are exact in int64)."""
    rng = np.random.default_rng(11)
    edges = np.array([I32[0], I32[1], 0, -1, 1, 4095, 4096, -4096, I32[0] + 1, I32[1] - 1])
    enc = np.concatenate([np.tile(edges, 3), rng.integers(*I32, 300, endpoint=True)])
    pot = np.concatenate([np.repeat(edges, 3), rng.integers(-100, 4200, 300)])
    lengths = [1, 2, 3, 1, 1, 2, 20]
    lengths += list(rng.integers(1, 40, 40))
    trial = np.repeat(np.arange(len(lengths)), lengths)[: len(enc)]
    assert len(trial) == len(enc)
    _check(c, enc, pot, trial)


def test_per_tick_twin_equals_whole_trial_twin(data_dir):
    """Pipeline (one call per tick, the controller's twin) == over_trials on one recorded trial."""
    df = load_split(data_dir, "test")
    df = df[df.trial == df.trial.iloc[0]]
    a = act_q_of()
    pipe = F.Pipeline(a)
    per_tick = [pipe.step(np.array([e]), np.array([p])) for e, p in zip(df.enc, df.pot, strict=True)]
    b = F.bases_q(a, df.enc, df.pot)
    d, dd = F.over_trials(b, df.trial.to_numpy())
    for k, want in enumerate((b, d, dd)):
        assert np.array_equal(np.concatenate([t[k] for t in per_tick], axis=1), want)


def test_derive_uses_the_same_warm_up(data_dir):
    """derive()'s float differences follow the twin's rule: zero at a trial's first sample, x[1] - x[0]
    and x[1] - 2 x[0] + x[0] (dd) at its second."""
    df = derive(load_split(data_dir, "test"))
    first = np.r_[True, df.trial.to_numpy()[1:] != df.trial.to_numpy()[:-1]]
    second = np.r_[False, first[:-1]]
    for i, base in F.BASE_NAMES.items():
        x = df[base].to_numpy()
        d, dd = df[F.name_of(F.D, i)].to_numpy(), df[F.name_of(F.DD, i)].to_numpy()
        assert (d[first] == 0).all() and (dd[first] == 0).all()
        x1, x0 = x[second], x[np.flatnonzero(second) - 1]
        assert np.array_equal(d[second], x1 - x0) and np.array_equal(dd[second], x1 - 2 * x0 + x0)


def test_value_of_every_kind(c):
    """sea_features_value == value for every kind and base signal, over int32 samples and histories."""
    ffi, lib = c.ffi, c.lib
    a = act_q_of()
    ca = CAct(ffi, a)
    rng = np.random.default_rng(5)
    cases = [(k, i) for k in (F.BASE, F.D, F.DD) for i in range(F.N_BASE)] + [(F.ANGLE, 0)]
    for _ in range(300):
        b, p1, p2 = rng.integers(-(2**31), 2**31, (3, F.N_BASE)) >> rng.integers(0, 31, (3, F.N_BASE))
        f = ffi.new(
            "sea_features_out *", {k: [int(v) for v in a] for k, a in (("b", b), ("p1", p1), ("p2", p2))}
        )
        diff = F.Differences()
        diff.p1, diff.p2 = p1, p2
        f.act = ca.ptr
        d, dd = diff(b)
        for kind, i in cases:
            got, want = lib.sea_features_value(f, kind, i), int(F.value(a, kind, i, b, d, dd))
            assert got == want, (kind, i, b.tolist(), p1.tolist(), p2.tolist())


SANITIZED_MAIN = r"""
#include <stdio.h>
#include "sea_features.h"
/* stdin: the table, the scalar sea_act fields, then (enc, pot, reset) rows; stdout: b, d, dd per base
 * signal and the angle. */
int main(void)
{
    int32_t table[SEA_LINK_TABLE_LEN];
    int32_t v[12];
    sea_act a;
    sea_features_state s;
    sea_features_out f;
    long e, p, r;
    int k;
    for (k = 0; k < SEA_LINK_TABLE_LEN; ++k) {
        if (scanf("%ld", &e) != 1) return 2;
        table[k] = (int32_t)e;
    }
    for (k = 0; k < 12; ++k) {
        if (scanf("%ld", &e) != 1) return 2;
        v[k] = (int32_t)e;
    }
    a.link_q16 = table;
    a.link_shift = v[0]; a.link_i32_bits = v[1]; a.pot_max = v[2]; a.travel_q = v[3]; a.travel_shift = v[4];
    a.enc_i32_bits = v[5]; a.pot_deg_q24 = v[6]; a.pot_offset_q24 = v[7]; a.motor_max_mv = v[8];
    a.enc_jump_max = v[9]; a.pot_avg_ticks = v[10]; a.pot_stuck_ticks = v[11];
    sea_features_reset(&s);
    while (scanf("%ld %ld %ld", &e, &p, &r) == 3) {
        if (r) sea_features_reset(&s);
        sea_features_step(&s, &a, (int32_t)e, (int32_t)p, &f);
        for (k = 0; k < SEA_FEAT_N_BASE; ++k)
            printf("%ld %lld %lld ", (long)f.b[k], (long long)sea_features_value(&f, SEA_FEAT_D, k),
                   (long long)sea_features_value(&f, SEA_FEAT_DD, k));
        printf("%lld\n", (long long)sea_features_value(&f, SEA_FEAT_ANGLE, 0));
    }
    return 0;
}
"""


def test_sanitized_edges():
    """Under UBSan+ASan the pipeline runs the int32 edge sequence without a report, with the twin's values."""
    import subprocess

    from seagen.toolchain.host import build_exe

    exe = build_exe({**runtime_sources(*SOURCES), "main.c": SANITIZED_MAIN}, name="features_san")
    rng = np.random.default_rng(3)
    edges = np.array([I32[0], I32[1], 0, -1, 4095, 4096, -4096])
    enc = np.concatenate([np.tile(edges, 7), rng.integers(*I32, 100, endpoint=True)])
    pot = np.concatenate([np.repeat(edges, 7), rng.integers(*I32, 100, endpoint=True)])
    reset = np.r_[1, np.zeros(len(enc) - 1, int)]
    reset[[20, 21, 60]] = 1
    a = act_q_of()
    text = (
        " ".join(map(str, a.link))
        + "\n"
        + " ".join(str(v) for _, v in a.struct_fields())
        + "\n"
        + "\n".join(f"{e} {p} {r}" for e, p, r in zip(enc, pot, reset, strict=True))
    )
    res = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr
    got = np.array([line.split() for line in res.stdout.splitlines()], dtype=np.int64)
    b = F.bases_q(a, enc, pot)
    d, dd = F.over_trials(b, np.cumsum(reset))
    want = np.column_stack(
        [*(np.stack([b[k], d[k], dd[k]], axis=1) for k in range(F.N_BASE)), F.angle_q24(a, pot)]
    )
    assert np.array_equal(got, want)
