"""Each sea_nn kernel in C (c_runtime/sea_nn.c) alone equals its Python twin (seagen/runtime/nn.py).

Tables of shapes, shifts and edge values; accumulator-width cases respect the contract the generator
proves (an int32 accumulator only where every partial sum fits), so no case exercises undefined behaviour.
"""

from __future__ import annotations

import numpy as np
import pytest

from seagen.codegen.runtime import cdef_of, runtime_sources
from seagen.runtime import nn as K
from seagen.toolchain.host import build

HEADERS = ("sea_fixed.h", "sea_nn.h")
I16 = (-(2**15), 2**15 - 1)
I32 = (-(2**31), 2**31 - 1)
EDGE16 = np.array([I16[0], I16[1], 0, 1, -1, 2, -2, I16[0] + 1, I16[1] - 1])


@pytest.fixture(scope="module")
def c():
    """sea_fixed and sea_nn built with the strict flags; declarations from the headers."""
    return build(
        cdef_of(*runtime_sources(*HEADERS).values()), runtime_sources(*HEADERS, "sea_fixed.c", "sea_nn.c")
    )


def _buf(c, ctype: str, values) -> object:
    return c.ffi.new(f"{ctype}[]", [int(v) for v in np.ravel(values)])


def _i16(rng: np.random.Generator, n: int) -> np.ndarray:
    """n int16 values: the edge values first, then random ones."""
    return np.concatenate([EDGE16, rng.integers(I16[0], I16[1], n, endpoint=True)])[:n]


DENSE = [  # (n_in, n_out, weight bits, accumulator bits, shift)
    (1, 1, 16, 32, 0),
    (1, 1, 16, 64, 62),
    (3, 5, 16, 32, 1),
    (9, 16, 16, 32, 15),
    (9, 16, 16, 64, 30),
    (16, 32, 8, 32, 7),
    (32, 1, 8, 64, 40),
    (7, 8, 16, 64, 0),
    (2, 3, 8, 32, 30),
]


@pytest.mark.parametrize("n_in,n_out,wbits,abits,shift", DENSE)
def test_dense(c, n_in, n_out, wbits, abits, shift):
    """sea_dense_w{8,16}_a{32,64} == dense: extreme inputs and weights; int32 cases keep every partial sum
    inside int32 (as the generator proves), int64 cases use the full int16 x int16 range."""
    rng = np.random.default_rng(n_in * 100 + n_out + shift)
    wmax = 2 ** (wbits - 1) - 1
    if abits == 32:
        budget = (I32[1] // 2) // (n_in * 2**15)  # |b| < 2^30 and sum |w| |x| < 2^30
        wmax = min(wmax, max(budget, 1))
        b = rng.integers(-(2**30) + 1, 2**30, n_out)
    else:
        b = rng.integers(-(2**62), 2**62, n_out)
    fn = getattr(c.lib, f"sea_dense_w{wbits}_a{abits}")
    for trial in range(20):
        w = rng.integers(-wmax, wmax + 1, (n_out, n_in))
        if trial == 0 and abits == 64:
            w[:] = wmax  # the largest products, all of one sign
        x = _i16(rng, n_in) if trial % 2 else rng.choice(EDGE16, n_in)
        y = c.ffi.new("int16_t[]", n_out)
        wb = _buf(c, f"int{wbits}_t", w)
        fn(wb, _buf(c, f"int{abits}_t", b), _buf(c, "int16_t", x), n_in, n_out, shift, y)
        want = K.dense(w, b, x[None, :].astype(np.int64), shift)[0]
        assert np.array_equal(list(y), want), (trial, x.tolist())


def _inplace(c, fn: str, y: np.ndarray, *args) -> np.ndarray:
    """Run an in-place activation kernel on a copy of y."""
    buf = _buf(c, "int16_t", y)
    getattr(c.lib, fn)(buf, len(y), *args)
    return np.array(list(buf), dtype=np.int64)


Y = _i16(np.random.default_rng(3), 4000)


def test_clamp(c):
    """sea_clamp_s16 == clamp_s16 with per-element boxes, including empty boxes at the int16 ends."""
    rng = np.random.default_rng(1)
    lo = rng.integers(I16[0], I16[1], len(Y))
    hi = np.maximum(lo, rng.integers(I16[0], I16[1], len(Y)))
    lo[:3], hi[:3] = I16[0], I16[1]
    out = c.ffi.new("int16_t[]", len(Y))
    c.lib.sea_clamp_s16(_buf(c, "int16_t", Y), _buf(c, "int16_t", lo), _buf(c, "int16_t", hi), len(Y), out)
    assert np.array_equal(list(out), K.clamp_s16(Y, lo, hi))


@pytest.mark.parametrize("alpha", [0, 1, 328, 1638, 16384, 32767])
def test_relu_and_leaky(c, alpha):
    """sea_relu_s16 == relu_s16; sea_leaky_s16 == leaky_s16 for slopes 0..1 in Q15 (ties included)."""
    assert np.array_equal(_inplace(c, "sea_relu_s16", Y), K.relu_s16(Y))
    assert np.array_equal(_inplace(c, "sea_leaky_s16", Y, alpha), K.leaky_s16(Y, alpha))


@pytest.mark.parametrize("lo,hi", [(-16384, 16384), (I16[0], I16[1]), (0, 0), (-1, 1)])
def test_hardtanh(c, lo, hi):
    """sea_hardtanh_s16 == hardtanh_s16."""
    assert np.array_equal(_inplace(c, "sea_hardtanh_s16", Y, lo, hi), K.hardtanh_s16(Y, lo, hi))


@pytest.mark.parametrize("length,in_shift,offset", [(1, 0, 0), (257, 8, 128), (2049, 4, 1024), (64, 15, -3)])
def test_table(c, length, in_shift, offset):
    """sea_table_s16 == table_s16: index rounding, offset and clamping at both ends of the table."""
    table = np.random.default_rng(length).integers(I16[0], I16[1], length)
    got = _inplace(c, "sea_table_s16", Y, _buf(c, "int16_t", table), length, in_shift, offset)
    assert np.array_equal(got, K.table_s16(Y, table, in_shift, offset))


HORNER = [(0, 0), (0, 14), (12, 20), (30, 30), (20, 62), (31, 45)]  # (align, shift)


@pytest.mark.parametrize("align,shift", HORNER)
def test_horner(c, align, shift):
    """sea_horner_s32 == horner_s32 where |x t| + |add| 2^align < 2^62 (the generator's proof)."""
    rng = np.random.default_rng(align * 64 + shift)
    x = _i16(rng, 600)
    t = rng.integers(*I32, 600, endpoint=True)
    t[:9] = [I32[0], I32[1], 0, 1, -1, I32[0], I32[1], 2**20, -(2**20)]
    amax = min(I32[1], (2**61) >> align)
    add = rng.integers(-amax, amax + 1, 600)
    got = [
        c.lib.sea_horner_s32(int(a), int(b), int(d), align, shift) for a, b, d in zip(x, t, add, strict=True)
    ]
    assert np.array_equal(got, K.horner_s32(x, t, add, align, shift))


CONVERT = [(0, 0), (16, 0), (0, 14), (24, 10), (16, 16), (10, 16), (62, 0), (0, 40), (-2, 3)]


@pytest.mark.parametrize("from_frac,to_frac", CONVERT)
def test_to_s16_and_to_s32(c, from_frac, to_frac):
    """sea_to_s16 / sea_to_s32 == to_s16 / to_s32: rounding down, exact scaling up, saturation."""
    rng = np.random.default_rng((from_frac + 10) * 100 + to_frac)
    up = max(to_frac - from_frac, 0)
    vmax = (2**62) >> up  # the contract: |v| 2^up < 2^63
    v = np.concatenate([[0, 1, -1, I16[0], I16[1], I32[0], I32[1]], rng.integers(-vmax, vmax, 800)])
    v = np.concatenate([v, (np.arange(-20, 20) << max(from_frac - to_frac - 1, 0))])
    v = np.clip(v, -vmax, vmax)
    assert np.array_equal(
        [c.lib.sea_to_s16(int(a), from_frac, to_frac) for a in v], K.to_s16(v, from_frac, to_frac)
    )
    assert np.array_equal(
        [c.lib.sea_to_s32(int(a), from_frac, to_frac) for a in v], K.to_s32(v, from_frac, to_frac)
    )
