"""The fixed-point primitives in C (c_runtime/sea_fixed.c) equal their Python twins bit for bit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from seagen.codegen.runtime import FIXED, cdef_of, runtime_sources
from seagen.runtime import fixed as P
from seagen.runtime.actq import act_q_of
from seagen.toolchain.actc import CAct
from seagen.toolchain.host import build

CDEF = cdef_of(runtime_sources("sea_fixed.h")["sea_fixed.h"])


@pytest.fixture(scope="module")
def c():
    """The runtime built with the strict flags."""
    return build(CDEF, runtime_sources(*FIXED), name="prims")


def _first_mismatch(a: np.ndarray, b: np.ndarray, inputs: np.ndarray) -> str:
    i = int(np.argmax(a != b))
    return f"first mismatch at input {inputs[i]}: C {a[i]} vs Python {b[i]}"


RNG = np.random.default_rng(7)
EDGE64 = np.array([0, 1, -1, 2, -2, 3, -3, 2**62, -(2**62), 2**63 - 1, -(2**63)], dtype=np.int64)
CASES_64 = np.concatenate([EDGE64, RNG.integers(-(2**62), 2**62, 3000), RNG.integers(-5000, 5000, 3000)])


@pytest.mark.parametrize("s", [0, 1, 2, 3, 7, 8, 15, 16, 24, 31, 40, 62])
def test_rshift_rne_s64(c, s):
    """sea_rshift_rne_s64 == rshift_rne for every int64 input incl. extremes and exact ties."""
    v = np.concatenate([CASES_64, (np.arange(-40, 40, dtype=np.int64) << np.int64(max(s - 1, 0)))])
    got = np.array([c.lib.sea_rshift_rne_s64(int(x), s) for x in v], dtype=np.int64)
    want = P.rshift_rne(v, s)
    assert np.array_equal(got, want), _first_mismatch(got, want, v)


@pytest.mark.parametrize("s", [0, 1, 5, 15, 30])
def test_rshift_rne_s32(c, s):
    """sea_rshift_rne_s32 == rshift_rne on int32 inputs, ties included."""
    v = np.concatenate([RNG.integers(-(2**31), 2**31, 2000), [-(2**31), 2**31 - 1, 0, -1, 1]]).astype(
        np.int64
    )
    got = np.array([c.lib.sea_rshift_rne_s32(int(x), s) for x in v], dtype=np.int64)
    want = P.rshift_rne(v, s)
    assert np.array_equal(got, want), _first_mismatch(got, want, v)


def test_rshift_rne_is_round_half_even():
    """The Python rule equals np.rint of the exact quotient (ties to even)."""
    v = np.arange(-5000, 5000, dtype=np.int64)
    for s in (1, 3, 8):
        assert np.array_equal(P.rshift_rne(v, s), np.rint(v / 2.0**s).astype(np.int64))


def test_saturation(c):
    """sea_sat16/sea_sat32 clamp instead of wrapping."""
    v = np.concatenate([EDGE64, RNG.integers(-(2**40), 2**40, 500)])
    assert np.array_equal([c.lib.sea_sat16(int(x)) for x in v], P.sat16(v))
    assert np.array_equal([c.lib.sea_sat32(int(x)) for x in v], P.sat32(v))


def test_compression_pipeline(c):
    """sea_compression_q16 == compression_q16 over every pot and a sweep of encoder counts."""
    a = act_q_of()
    ct = CAct(c.ffi, a)
    pot = np.concatenate([np.arange(-10, 4110), RNG.integers(-(2**31), 2**31, 200)])
    enc = RNG.integers(-(2**31), 2**31, pot.size)
    enc[:4120] = RNG.integers(-3000, 6000, 4120)
    got = np.array(
        [c.lib.sea_compression_q16(ct.ptr, int(e), int(p)) for e, p in zip(enc, pot, strict=True)],
        dtype=np.int64,
    )
    want = P.compression_q16(a, enc, pot)
    assert np.array_equal(got, want), _first_mismatch(got, want, np.stack([enc, pot], 1))


def test_compression_int32_paths_at_their_limits(c):
    """sea_linkage_q16 / sea_compression_q16 take int32 paths where the table entries lie in [-2^26, 2^26) and
    enc in [-2^14, 2^14), int64 paths beyond: both equal the twin, at the limits and on tables up to 2^30."""
    for lim in (2**26, 2**30 - 1):
        table = RNG.integers(-lim, lim + 1, 257)
        table[:4] = [-(2**26), 2**26 - 1, 2**26, -(2**26) - 1] if lim == 2**26 else [-lim, lim, -lim, lim]
        a = replace(act_q_of(), link=tuple(int(x) for x in table))
        ct = CAct(c.ffi, a)
        edges = [-(2**31), -(2**14) - 1, -(2**14), -(2**14) + 1, -1, 0, 2**14 - 1, 2**14, 29183, 2**31 - 1]
        enc = np.concatenate([np.repeat(edges, 8), RNG.integers(-(2**15), 2**15, 400)])
        pot = RNG.integers(-5, 4101, enc.size)
        pot[:80] = np.tile(np.arange(0, 80, 8), 8)
        got = np.array(
            [c.lib.sea_compression_q16(ct.ptr, int(e), int(q)) for e, q in zip(enc, pot, strict=True)]
        )
        want = P.compression_q16(a, enc, pot)
        assert np.array_equal(got, want), _first_mismatch(got, want, np.stack([enc, pot], 1))


def test_compression_matches_float_geometry():
    """The fixed-point compression stays within 1.5e-4 mm of Eq. 2 in floating point over the working range.

    Bound: interpolation CB*h^2/8 (h = 16 counts = 0.00362 rad) = 5.9e-5, Q24 constant 0.28/2^24 per count
    over 3000 counts = 5.0e-5, two roundings to Q16 = 1.5e-5 mm: 1.24e-4 mm.
    """
    from seagen.geometry import geometry

    pot = np.arange(380, 2400)
    enc = np.linspace(-200, 3000, pot.size).astype(np.int64)
    fixed = P.compression_q16(act_q_of(), enc, pot) / 2.0**16
    g = geometry()
    exact = g.compression_mm(g.angle_from_pot(pot), enc)
    assert np.max(np.abs(fixed - exact)) < 1.5e-4
