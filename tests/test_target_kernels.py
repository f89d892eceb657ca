"""Target MLP kernels (--target cortex-m4 / cortex-m0plus) are bit-exact with the numpy reference: each on its
own emulated core, and on the host (the M4 kernel through its portable SMLAD fallback, also under UBSan+ASan).

About 35 s with -n 2 (cross-compiling and emulating dominate)."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.codegen.render import render
from seagen.codegen.targets import kernel_context
from seagen.data.schema import load_split
from seagen.defaults import DEFAULT_PREFIX, GENERATED
from seagen.errors import UserError
from seagen.export import prepare
from seagen.ir import FloatLayer, FloatMLP, Signal
from seagen.quant.mlp import quantize_mlp
from seagen.reference import numpy_ref
from seagen.runtime.fixed import rshift_rne
from seagen.toolchain.equivalence import edge_inputs, first_mismatch, random_inputs, recorded, step_problem
from seagen.toolchain.model import CModel, sanitized_infer

MODELS = sorted(DEFAULT_PREFIX)  # both MLPs and both surface fits
TARGETS = ("cortex-m4", "cortex-m0plus")
KEYS = [(m, t) for m in MODELS for t in TARGETS]
IDS = [f"{m}-{t}" for m, t in KEYS]


@pytest.fixture(scope="module")
def exports():
    """Every default model exported for each target kernel, keyed by (model, target)."""
    return {
        (m, t): prepare(str(GENERATED / "models" / f"{m}.pt"), prefix=DEFAULT_PREFIX[m], target=t)
        for m, t in KEYS
    }


def _cases(qm) -> np.ndarray:
    return np.vstack([random_inputs(qm, 400, 11), edge_inputs(len(qm.inputs))])


@pytest.mark.parametrize("key", KEYS, ids=IDS)
def test_host_build_bit_exact(exports, key, data_dir):
    """On the host (no SIMD32: the portable fallbacks), NAME_infer and NAME_step equal the numpy reference."""
    ex = exports[key]
    qm = ex.qmodel
    c = CModel(ex.files, ex.prefix, qm)
    x = _cases(qm)
    assert first_mismatch(c.infer(x), numpy_ref.infer(qm, x), x) is None
    assert step_problem(qm, c, *recorded(qm, load_split(data_dir, "test"))) is None


@pytest.mark.parametrize("model", MODELS)
def test_m4_fallback_sanitized(exports, model):
    """The M4 kernel's portable fallback is clean under UBSan+ASan on random and edge inputs, same output."""
    ex = exports[(model, "cortex-m4")]
    x = _cases(ex.qmodel)
    got = sanitized_infer(ex.files, ex.prefix, ex.qmodel, x)
    assert first_mismatch(got, numpy_ref.infer(ex.qmodel, x), x) is None


@pytest.mark.parametrize("key", KEYS, ids=IDS)
def test_on_own_core_bit_exact(exports, key, data_dir):
    """Each kernel cross-compiled for its own core equals numpy on random/edge inputs and recorded trials."""
    pytest.importorskip("unicorn", reason="unicorn (the Cortex-M emulator) is not installed")
    from seagen.toolchain.cortexm import CortexM, toolchain_missing

    if msg := toolchain_missing():
        pytest.skip(msg)
    ex = exports[key]
    qm = ex.qmodel
    mcu = CortexM(ex.files, ex.prefix, ex.qmodel, key[1])
    x = _cases(qm)
    assert first_mismatch(mcu.infer(x), numpy_ref.infer(qm, x), x) is None
    assert step_problem(qm, mcu, *recorded(qm, load_split(data_dir, "test"))) is None


def _odd_mlp(sizes: tuple[int, ...], scale: float, seed: int) -> FloatMLP:
    """A random ReLU MLP on wide-ranging inputs (odd sizes; large weights force 64-bit accumulators)."""
    rng = np.random.default_rng(seed)
    names = ("pot", "d_pot", "dd_pot", "enc", "compression_mm", "d_enc", "dd_enc", "d_compression_mm")
    inputs = tuple(Signal(names[i], "1", -100.0 * (i + 1), 80.0 * (i + 1)) for i in range(sizes[0]))
    layers = tuple(
        FloatLayer(
            rng.normal(0, scale, (b, a)), rng.normal(0, scale, b), "relu" if k < len(sizes) - 2 else "linear"
        )
        for k, (a, b) in enumerate(zip(sizes[:-1], sizes[1:], strict=True))
    )
    return FloatMLP(inputs, Signal("y", "1", -1e3, 1e3), layers)


SMALL = [((3, 5, 7, 1), 1.0, 3), ((8, 16, 8, 1), 10.0, 0), ((8, 16, 1), 10.0, 3), ((5, 1), 1.0, 3)]
SMALL_IDS = ["3-5-7-1", "8-16-8-1-wide", "8-16-1-wide", "5-1"]


@pytest.mark.parametrize("case", SMALL, ids=SMALL_IDS)
@pytest.mark.parametrize("target", TARGETS)
def test_odd_sizes_and_wide_accumulators_on_host(case, target):
    """Odd widths, single-layer nets and 64-bit accumulators: target kernels (host fallbacks) equal numpy."""
    qm = quantize_mlp(_odd_mlp(*case))
    files = {**render(qm, "odd", target), **prepare_runtime(target)}
    c = CModel(files, "odd", qm)
    x = _cases(qm)
    assert first_mismatch(c.infer(x), numpy_ref.infer(qm, x), x) is None


def _linear_hidden() -> FloatMLP:
    """A 5-6-3-1 MLP whose first hidden layer is linear (signed hidden outputs, the general pack)."""
    fm = _odd_mlp((5, 6, 3, 1), 1.0, 4)
    first = FloatLayer(fm.layers[0].weight, fm.layers[0].bias, "linear")
    return FloatMLP(fm.inputs, fm.output, (first, *fm.layers[1:]))


@pytest.mark.parametrize("case", [*SMALL, None], ids=[*SMALL_IDS, "5-6lin-3-1"])
def test_odd_sizes_on_m4_core(case):
    """The cases above and a linear hidden layer, cross-compiled for the Cortex-M4 and emulated, equal numpy:
    the kernel's odd passes, 64-bit passes, grouped loads and pair clamp (odd input count) on the core."""
    pytest.importorskip("unicorn", reason="unicorn (the Cortex-M emulator) is not installed")
    from seagen.toolchain.cortexm import CortexM, toolchain_missing

    if msg := toolchain_missing():
        pytest.skip(msg)
    qm = quantize_mlp(_odd_mlp(*case) if case else _linear_hidden())
    files = {**render(qm, "odd", "cortex-m4"), **prepare_runtime("cortex-m4")}
    x = _cases(qm)
    assert first_mismatch(CortexM(files, "odd", qm, "cortex-m4").infer(x), numpy_ref.infer(qm, x), x) is None


def test_wide_cases_exercise_64_bit_paths():
    """The wide cases above take each kernel's 64-bit path in a hidden layer and in the last layer."""
    for t in TARGETS:
        layers = [L for case in SMALL for L in kernel_context(quantize_mlp(_odd_mlp(*case)), t)["tlayers"]]
        assert any(L["acc"] == 64 and not L["last"] for L in layers), t
        assert any(L["acc"] == 64 and L["last"] for L in layers), t


def prepare_runtime(target: str) -> dict[str, str]:
    """The runtime files an export for `target` ships."""
    from seagen.codegen.render import RUNTIME
    from seagen.codegen.runtime import runtime_sources
    from seagen.codegen.targets import RUNTIME as EXTRA

    return runtime_sources(*RUNTIME, *EXTRA[target])


def test_dsp_helpers_match_python_twins():
    """sea_dsp.h fallbacks: both roundings (folded half, and the bias carrying 2^(s-1) - 1) == rshift_rne,
    SMLAD == exact sum, pack/unpack round-trip, the pair clamp == a clamp per half, the grouped loads, and
    both forms of the Horner product equal floor(x * r / 2^s) where the planner allows them."""
    import cffi

    from seagen.codegen.runtime import runtime_sources
    from seagen.toolchain.host import build

    cdef = (
        "int32_t t_rne32(int32_t v, int s); int64_t t_rne64(int64_t v, int s);"
        "int32_t t_smlad(int32_t x, int32_t w, int32_t a); int32_t t_pack(int32_t lo, int32_t hi);"
        "int32_t t_lo(int32_t w); int32_t t_hi(int32_t w); int32_t t_u2s(uint32_t u);"
        "int32_t t_split(int32_t x, int32_t r, int s); int32_t t_wide(int32_t x, int32_t r, int s);"
        "int32_t t_rneb32(int32_t u, int s); int64_t t_rneb64(int64_t u, int s);"
        "int32_t t_nnpack(int32_t lo, int32_t hi); int32_t t_clamp2(int32_t x, int32_t lo, int32_t hi);"
        "int32_t t_ld(const int32_t *p, int n);"
    )
    body = (
        '#include "sea_dsp.h"\n#include "t_dsp.h"\n'
        "int32_t t_rne32(int32_t v, int s) { return sea_rne_folded_s32(v, s); }\n"
        "int64_t t_rne64(int64_t v, int s) { return sea_rne_folded_s64(v, s); }\n"
        "int32_t t_smlad(int32_t x, int32_t w, int32_t a) { return sea_smlad(x, w, a); }\n"
        "int32_t t_pack(int32_t lo, int32_t hi) { return sea_pack16x2(lo, hi); }\n"
        "int32_t t_lo(int32_t w) { return sea_lo16(w); }\nint32_t t_hi(int32_t w) { return sea_hi16(w); }\n"
        "int32_t t_u2s(uint32_t u) { return sea_u32_to_s32(u); }\n"
        "int32_t t_split(int32_t x, int32_t r, int s) { return sea_mulshr_split_s32(x, r, s); }\n"
        "int32_t t_wide(int32_t x, int32_t r, int s) { return sea_mulshr_wide_s32(x, r, s); }\n"
        "int32_t t_rneb32(int32_t u, int s) { return sea_rne_bit_s32(u, s); }\n"
        "int64_t t_rneb64(int64_t u, int s) { return sea_rne_bit_s64(u, s); }\n"
        "int32_t t_nnpack(int32_t lo, int32_t hi) { return sea_pack_nonneg16x2(lo, hi); }\n"
        "int32_t t_clamp2(int32_t x, int32_t lo, int32_t hi) { return sea_clamp16x2(x, lo, hi); }\n"
        "int32_t t_ld(const int32_t *p, int n) {\n"
        "    int32_t a; int32_t b; int32_t c; int32_t d;\n"
        "    if (n == 2) { sea_ld2(p, &a, &b); return a - (3 * b); }\n"
        "    sea_ld4(p, &a, &b, &c, &d); return a - (3 * b) + (5 * c) - (7 * d);\n}\n"
    )
    header = "#include <stdint.h>\n" + cdef.replace(";", ";\n")
    lib = build(cdef, {**runtime_sources("sea_dsp.h"), "t_dsp.h": header, "t_dsp.c": body}, name="tdsp").lib
    rng = np.random.default_rng(5)
    for s in (1, 2, 7, 14, 16, 17, 30):
        half = 1 << (s - 1)
        vals = [*rng.integers(-(2**30), 2**30, 300).tolist(), -(2**30), 2**30 - 1, 0, 1, -1]
        vals += [k * (1 << s) + sign * half for k in (-3, -2, -1, 0, 1, 2) for sign in (1, -1)]
        for v in (v for v in vals if -(2**31) <= v + half < 2**31):
            assert lib.t_rne32(v + half, s) == int(rshift_rne(v, s)), (v, s)
            assert lib.t_rne64((v << 20) + (half << 20), s + 20) == int(rshift_rne(v << 20, s + 20)), (v, s)
            if s <= 30 and v + half - 1 >= -(2**31):  # sea_rne_bit_*: the bias carries 2^(s-1) - 1
                assert lib.t_rneb32(v + half - 1, s) == int(rshift_rne(v, s)), (v, s)
            u64 = (v << 20) + (half << 20) - 1
            assert lib.t_rneb64(u64, s + 20) == int(rshift_rne(v << 20, s + 20)), (v, s)
    pairs = rng.integers(-(2**15), 2**15, (500, 4)).tolist() + [[-(2**15)] * 4, [2**15 - 1] * 4]
    for a, b, c, d in pairs:
        x, w = lib.t_pack(a, b), lib.t_pack(c, d)
        assert (lib.t_lo(x), lib.t_hi(x)) == (a, b)
        assert lib.t_smlad(x, w, -12345) == -12345 + a * c + b * d  # within the proven bound
        if min(a, b) >= 0:
            assert lib.t_nnpack(a, b) == x
        lo, hi = lib.t_pack(min(a, c), min(b, d)), lib.t_pack(max(a, c), max(b, d))
        for y in (x, w, lib.t_pack(a, d), lib.t_pack(c, b)):
            lo_y = min(max(lib.t_lo(y), min(a, c)), max(a, c))
            want = lib.t_pack(lo_y, min(max(lib.t_hi(y), min(b, d)), max(b, d)))
            assert lib.t_clamp2(y, lo, hi) == want, (y, a, b, c, d)
    buf = cffi.FFI().new("int32_t[4]", [7, -11, 13, -17])
    assert (lib.t_ld(buf, 2), lib.t_ld(buf, 4)) == (7 + 33, 7 + 33 + 65 + 119)
    for u in (0, 1, 2**31 - 1, 2**31, 2**32 - 1):
        assert lib.t_u2s(u) == (u - 2**32 if u >= 2**31 else u)
    xs = [*rng.integers(-(2**15), 2**15, 200).tolist(), -(2**15), 2**15 - 1, 0, -1]
    rs = [*rng.integers(-(2**31), 2**31, 200).tolist(), -(2**31), 2**31 - 1, 0, -1, 65535, -65536]
    for x, r in zip(xs * 2, rs * 2, strict=False):
        for s in range(16, 47):  # the planner's MIN_SHIFT = 16
            want = (x * r) >> s  # Python ints: exact floor
            assert lib.t_split(x, r, s) == want, (x, r, s)
            if -(2**31) <= want < 2**31:
                assert lib.t_wide(x, r, s) == want, (x, r, s)


def test_bad_target_and_unsupported_shape_are_clear_errors():
    """An unknown --target, or a model with two outputs on a target kernel, is a UserError naming the fix; a
    tanh layer (applied per value, sea_nn.h) renders and equals numpy on both kernels."""
    qm = quantize_mlp(_odd_mlp((3, 4, 1), 0.5, 1))
    with pytest.raises(UserError, match="cortex-m0plus"):
        render(qm, "m", "cortex-m7")
    with pytest.raises(UserError, match="one output"):
        render(quantize_mlp(_odd_mlp((3, 4, 2), 0.5, 1)), "m", "cortex-m4")
    fm = _odd_mlp((3, 4, 1), 0.5, 1)
    tanh = FloatMLP(
        fm.inputs, fm.output, (FloatLayer(fm.layers[0].weight, fm.layers[0].bias, "tanh"), fm.layers[1])
    )
    qt = quantize_mlp(tanh)
    x = _cases(qt)
    for t in TARGETS:
        c = CModel({**render(qt, "m", t), **prepare_runtime(t)}, "m", qt)
        assert first_mismatch(c.infer(x), numpy_ref.infer(qt, x), x) is None, t


def test_32_bit_paths_of_sea_fixed_match_twins():
    """sea_rshift_rne_s64's int32 fast path, sea_div_rne_s32's unsigned 32-bit division (and its reciprocal
    path for divisors 1..16) and sea_to_s16's saturation decided before scaling equal the Python twins at the
    limits, on ties and on random values."""
    from seagen.codegen.runtime import FIXED, runtime_sources
    from seagen.runtime.fixed import div_rne
    from seagen.runtime.nn import to_s16
    from seagen.toolchain.host import build

    cdef = (
        "int64_t sea_rshift_rne_s64(int64_t v, int s); int32_t sea_div_rne_s32(int32_t num, int32_t den);"
        "int16_t sea_to_s16(int64_t v, int from_frac, int to_frac);"
    )
    lib = build(cdef, runtime_sources(*FIXED, "sea_nn.h", "sea_nn.c"), name="fixed32").lib
    rng = np.random.default_rng(9)
    edges = [-(2**31) - 1, -(2**31), -(2**31) + 1, -1, 0, 1, 2**31 - 2, 2**31 - 1, 2**31]
    for s in (1, 2, 13, 29, 30, 31):
        vals = (
            edges
            + rng.integers(-(2**32), 2**32, 300).tolist()
            + [k * (1 << s) + (1 << (s - 1)) for k in range(-4, 4)]
        )
        for v in vals:
            assert lib.sea_rshift_rne_s64(v, s) == int(rshift_rne(v, s)), (v, s)
    nums = [
        -(2**31),
        -(2**31) + 1,
        -7,
        -5,
        -1,
        0,
        1,
        5,
        7,
        2**31 - 1,
        *rng.integers(-(2**31), 2**31, 300).tolist(),
    ]
    dens = [*range(1, 18), 2**31 - 1, *rng.integers(1, 2**31, 20).tolist(), 0, -3]  # 1..16: no helper
    for n in nums:
        for d in dens:
            assert lib.sea_div_rne_s32(n, d) == int(div_rne(n, d)), (n, d)
    vs = [-(2**40), -(2**31), -32769, -32768, -4097, -4096, -1, 0, 1, 4095, 4096, 32767, 32768, 2**31, 2**40]
    vs += rng.integers(-(2**33), 2**33, 200).tolist() + rng.integers(-40000, 40000, 200).tolist()
    for v in vs:
        for frm, to in ((0, 0), (0, 3), (0, 10), (16, 11), (0, 15), (0, 16), (0, 20), (24, 10)):
            assert lib.sea_to_s16(v, frm, to) == int(to_s16(v, frm, to)), (v, frm, to)
