"""The smooth and piecewise-linear activations (ELU, SELU, Softplus, GELU erf/tanh, Mish, SiLU, HardSigmoid,
HardSwish, PReLU): each integer form within its stated error on every int16 input (the tables' worst samples
and both tails), C == numpy on every int16 input, a network using all of them bit for bit across numpy, the
torch twin, the quantized ONNX graph, the C (also under UBSan+ASan) and the Cortex-M kernels, and each read
from torch and ONNX files (ops, converters' patterns, hand-built graphs) within its proven bound of the
original run by torch or onnxruntime."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
from torch import nn

from seagen.codegen.render import render
from seagen.export import prepare
from seagen.ir import FloatLayer, FloatMLP, Signal
from seagen.quant.mlp import quantize_mlp
from seagen.reference import numpy_ref, torch_ref
from seagen.reference.float_ref import quantize_features
from seagen.reference.onnx_ref import build_onnx
from seagen.reference.oracle import box_points
from seagen.runtime import activations as A
from seagen.toolchain.equivalence import edge_inputs, random_inputs
from seagen.toolchain.model import CModel, sanitized_infer

ALL = np.arange(-(2**15), 2**15, dtype=np.int64)
SLOPES = (-0.5, -0.1, 0.0, 0.2, 0.25, 0.6, 0.9, 1.0)
VARIANTS = {  # name: (IR activation, params)
    "elu": ("elu", (1.0,)),
    "elu_0.7": ("elu", (0.7,)),
    "selu": ("selu", A.SELU),
    "softplus_onnx": ("softplus", (1.0, math.inf)),
    "softplus_b2_t10": ("softplus", (2.0, 10.0)),
    "gelu": ("gelu", ()),
    "gelu_tanh": ("gelu_tanh", ()),
    "mish": ("mish", ()),
    "silu": ("silu", ()),
    "hardsigmoid_onnx": ("hardsigmoid", (0.2, 0.5)),
    "hardsigmoid_torch": ("hardsigmoid", (1.0 / 6.0, 0.5)),
    "hardswish": ("hardswish", A.HARDSWISH),
}


def _integer_and_bound(act: str, p: tuple, f: int) -> tuple[np.ndarray, float, float]:
    """Every int16 input at Q(f) through the integer form: outputs (real units), the stated worst error,
    and the output LSB."""
    xmax = 2.0 ** (15 - f)
    if act in A.SMOOTH:
        t = A.smooth_table(act, p, f, -(2**15), 2**15 - 1, "t")
        y = A.smooth_s16(ALL, t, A.slope_q(act, p)) * 2.0**-f
        return y, A.smooth_error(act, p, t, xmax), 2.0**-f
    a_q, b_q = A.hsig_params(p[0], p[1], f)
    if act == "hardsigmoid":
        y = A.hsig_s16(ALL, a_q, b_q) * 2.0**-A.TABLE_OUT_FRAC
        return y, A.hsig_error(p[0], p[1], a_q, b_q, f, xmax), 2.0**-A.TABLE_OUT_FRAC
    return A.hswish_s16(ALL, a_q, b_q) * 2.0**-f, A.hswish_error(a_q, b_q, f, xmax), 2.0**-f


@pytest.mark.parametrize("frac", [5, 9, 12])
@pytest.mark.parametrize("key", list(VARIANTS))
def test_every_int16_input_within_stated_error(key, frac):
    """Exhaustive over int16 at Q(frac) (x up to +-1024, +-64, +-8: the tails beyond each table's radius,
    every sample and the points between): |integer - f(x)| <= the error the bound adds, and the error is
    not vacuous (the worst case reaches at least a fifth of it, or half an output LSB)."""
    act, p = VARIANTS[key]
    y, bound, lsb = _integer_and_bound(act, p, frac)
    err = np.abs(y - A.act_float(act, p, ALL * 2.0**-frac))
    if (
        act in A.SMOOTH
    ):  # the inputs a layer's format admits: s |x| + sup |g| fits int16 (quant/activation.py)
        s, gmax = A.slope(act, p), A.shape_of(act, p).gmax
        err = err[s * np.abs(ALL) + gmax * 2.0**frac + 1 <= 2**15 - 1]
    assert err.max() <= bound, (key, frac, err.max(), bound, ALL[err.argmax()])
    assert err.max() >= min(bound / 5, lsb / 2), (key, frac, err.max(), bound)


@pytest.mark.parametrize("slopes", [(-0.5, -0.125, 0.0, 0.25, 0.5, 0.75, 0.875, 1.0), SLOPES])
def test_prelu_exact_but_for_rounding(slopes):
    """PReLU on every int16 input, a slope per channel: within |a - a_q| |x| + half an LSB (the slope's Q15
    rounding and the one rounding shift; slopes Q15 holds exactly: half an LSB)."""
    a_q = np.array([round(s * 2**15) for s in slopes])
    y = A.prelu_s16(ALL[:, None], a_q[None, :])
    a = np.array(slopes)[None, :]
    want = np.where(ALL[:, None] >= 0, ALL[:, None], ALL[:, None] * a)
    stated = np.abs(a - a_q / 2**15) * np.abs(ALL[:, None]) + 0.5
    assert np.all(np.abs(y - want) <= stated)


def test_c_primitives_equal_twins_on_every_int16():
    """sea_smooth_s16 / sea_hsig_s16 / sea_hswish_s16 / sea_prelu_s16 == their Python twins on all int16."""
    from seagen.codegen.runtime import runtime_sources
    from seagen.toolchain.host import build

    cdef = (
        "void sea_smooth_s16(int16_t *y, int n, const int16_t *g, int32_t len, int in_shift, int32_t offset,"
        " int32_t slope); void sea_hsig_s16(int16_t *y, int n, int32_t alpha, int64_t beta);"
        "void sea_hswish_s16(int16_t *y, int n, int32_t alpha, int64_t beta);"
        "void sea_prelu_s16(int16_t *y, int n, const int32_t *alpha);"
    )
    src = runtime_sources("sea_fixed.h", "sea_fixed.c", "sea_nn.h", "sea_nn.c")
    mod = build(
        cdef, {**src, "t_act.h": '#include "sea_nn.h"\n', "t_act.c": '#include "t_act.h"\n'}, name="tact"
    )
    ffi, lib = mod.ffi, mod.lib

    def run(fn, *args) -> np.ndarray:
        y = ALL.astype(np.int16)
        fn(ffi.from_buffer("int16_t[]", y), len(y), *args)
        return y.astype(np.int64)

    for act, p in (VARIANTS["selu"], VARIANTS["gelu"], VARIANTS["softplus_b2_t10"], VARIANTS["mish"]):
        for f in (3, 10):
            t = A.smooth_table(act, p, f, -(2**15), 2**15 - 1, "t")
            g = np.ascontiguousarray(t.values, dtype=np.int16)
            s_q = A.slope_q(act, p)
            got = run(lib.sea_smooth_s16, ffi.from_buffer("int16_t[]", g), len(g), t.in_shift, t.offset, s_q)
            assert np.array_equal(got, A.smooth_s16(ALL, t, s_q)), (act, f)
    for f in (-2, 7, 13):
        a_q, b_q = A.hsig_params(1.0 / 6.0, 0.5, f)
        assert np.array_equal(run(lib.sea_hsig_s16, a_q, b_q), A.hsig_s16(ALL, a_q, b_q)), f
        assert np.array_equal(run(lib.sea_hswish_s16, a_q, b_q), A.hswish_s16(ALL, a_q, b_q)), f
    for s in SLOPES:  # one slope per call: the same for every channel
        a = np.full(len(ALL), round(s * 2**15), dtype=np.int32)
        got = run(lib.sea_prelu_s16, ffi.from_buffer("int32_t[]", a))
        assert np.array_equal(got, A.prelu_s16(ALL, a.astype(np.int64))), s


def _chain() -> FloatMLP:
    """A network with every activation in a row (4 wide; the inputs and weights give pre-activations of a
    few units, beyond every table's end for some inputs)."""
    rng = np.random.default_rng(7)
    acts = [(a, p) for a, p in (VARIANTS[k] for k in ("elu_0.7", "selu", "softplus_b2_t10", "gelu"))]
    acts += [(a, p) for a, p in (VARIANTS[k] for k in ("gelu_tanh", "mish", "silu", "hardsigmoid_onnx"))]
    acts += [("hardswish", A.HARDSWISH), ("prelu", (0.25, -0.1, 0.6, 0.9))]
    layers = [
        FloatLayer(rng.normal(0, 2, (4, 3 if not k else 4)), rng.normal(size=4), a, params=p)
        for k, (a, p) in enumerate(acts)
    ]
    layers.append(FloatLayer(rng.normal(size=(1, 4)), rng.normal(size=1)))
    names = ("pot", "enc", "d_enc")
    ins = tuple(
        Signal(n, "1", lo, hi)
        for n, (lo, hi) in zip(names, ((1000.0, 3000.0), (0.0, 500.0), (-5.0, 5.0)), strict=True)
    )
    return FloatMLP(ins, Signal("y", "1", -10.0, 10.0), tuple(layers))


@pytest.fixture(scope="module")
def chain():
    qm = quantize_mlp(_chain())
    x = np.vstack([random_inputs(qm, 1500, 3), edge_inputs(len(qm.inputs))])
    return qm, x, numpy_ref.infer(qm, x)


def test_chain_bit_exact_numpy_torch_onnx_c_ubsan(chain):
    """Every activation in one network: numpy == torch twin == onnxruntime on the quantized graph == the C,
    and the C built with UBSan+ASan runs clean with the same integers."""
    import onnxruntime as ort

    qm, x, want = chain
    assert np.array_equal(torch_ref.infer(qm, x), want)
    sess = ort.InferenceSession(build_onnx(qm).SerializeToString())
    assert np.array_equal(sess.run(None, {"x": x.astype(np.int16)})[0].astype(np.int64), want)
    files = {**render(qm, "smo"), **_runtime("portable")}
    assert np.array_equal(CModel(files, "smo", qm).infer(x), want)
    assert np.array_equal(sanitized_infer(files, "smo", qm, x), want)


def _runtime(target: str) -> dict[str, str]:
    from seagen.codegen.render import RUNTIME
    from seagen.codegen.runtime import runtime_sources
    from seagen.codegen.targets import RUNTIME as EXTRA

    return runtime_sources(*RUNTIME, *EXTRA[target])


@pytest.mark.parametrize("target", ["cortex-m4", "cortex-m0plus"])
def test_chain_target_kernels_on_host(chain, target):
    """The Cortex-M kernels (their portable fallbacks on the host) give the same integers."""
    qm, x, want = chain
    files = {**render(qm, "smo", target), **_runtime(target)}
    assert np.array_equal(CModel(files, "smo", qm).infer(x), want)


@pytest.mark.slow
@pytest.mark.parametrize("target", ["cortex-m4", "cortex-m0plus"])
def test_chain_on_emulated_core(chain, target):
    """Each Cortex-M kernel cross-compiled for its core and emulated (unicorn): the same integers."""
    pytest.importorskip("unicorn", reason="unicorn (the Cortex-M emulator) is not installed")
    from seagen.toolchain.cortexm import CortexM, toolchain_missing

    if msg := toolchain_missing():
        pytest.skip(msg)
    qm, x, want = chain
    files = {**render(qm, "smo", target), **_runtime(target)}
    assert np.array_equal(CortexM(files, "smo", qm, target).infer(x[:400]), want[:400])


# ---- read from the files people write, checked against the original -----------------------------------

NAMES = ["pot", "enc", "d_enc"]
RANGE = [[-2.0, 2.0], [-3.0, 1.0], [-1.0, 1.5]]
MODULES = {
    "elu": lambda: nn.ELU(0.7),
    "selu": nn.SELU,
    "softplus": lambda: nn.Softplus(2.0, 10.0),
    "gelu": nn.GELU,
    "gelu_tanh": lambda: nn.GELU("tanh"),
    "mish": nn.Mish,
    "silu": nn.SiLU,
    "hardsigmoid": nn.Hardsigmoid,
    "hardswish": nn.Hardswish,
    "prelu": lambda: nn.PReLU(8),
}


def _spec(d: Path) -> str:
    p = d / "features.json"
    p.write_text(json.dumps({"inputs": NAMES, "input_range": RANGE, "output_name": "f", "output_units": "N"}))
    return str(p)


def _net(act: str, seed: int) -> nn.Sequential:
    torch.manual_seed(seed)
    net = nn.Sequential(nn.Linear(3, 8), MODULES[act](), nn.Linear(8, 1)).eval()
    with torch.no_grad():
        net[0].weight.mul_(3.0)  # pre-activations of several units: both tails of every table
        if act == "prelu":
            net[1].weight.copy_(torch.linspace(-0.5, 0.9, 8))
    return net


def _torch_original(net: nn.Module):
    return lambda x: net(torch.as_tensor(x, dtype=torch.float32)).detach().double().numpy()[:, 0]


def _ort_original(path: Path):
    import onnxruntime as ort

    sess = ort.InferenceSession(str(path))
    name = sess.get_inputs()[0].name
    return lambda x: np.asarray(sess.run(None, {name: x.astype(np.float32)})[0], dtype=float).reshape(len(x))


def _within_bound(path: Path, spec: str, original) -> float:
    """Export (the tool's own oracle check runs), then |integer - original| on box points <= bound + the
    stated margin for the original's rounding; returns the worst error as a fraction of the bound."""
    ex = prepare(str(path), prefix="m", features=spec)
    qm = ex.qmodel
    x = box_points(qm, 400, seed=2)
    got = numpy_ref.infer(qm, quantize_features(qm, x)) * 2.0**-qm.out_frac
    err = float(np.max(np.abs(got - original(x))))
    assert ex.loaded is not None
    assert err <= qm.error_bound + ex.loaded.margin, (path.name, err, qm.error_bound)
    return err / qm.error_bound


def _quiet(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*a, **k)


FAST_MODULES = ("gelu", "silu", "hardswish", "prelu")  # the rest in the slow suite


@pytest.mark.parametrize(
    "act", [a if a in FAST_MODULES else pytest.param(a, marks=pytest.mark.slow) for a in MODULES]
)
def test_torch_module_within_bound(act, tmp_path):
    """An nn.Sequential saved whole, read through its modules: within the bound of its own forward."""
    net = _net(act, 1)
    torch.save(net, tmp_path / "m.pt")
    _within_bound(tmp_path / "m.pt", _spec(tmp_path), _torch_original(net))


@pytest.mark.slow
@pytest.mark.parametrize("act", list(MODULES))
@pytest.mark.parametrize("form", ["pt2", "script", "onnx_legacy", "onnx_dynamo"])
def test_torch_exports_within_bound(act, form, tmp_path):
    """The same network as a .pt2 (ATen ops), TorchScript, and through both of torch's ONNX exporters (the
    legacy one writes GELU's erf and tanh patterns, x*sigmoid(x), Mish as softplus/tanh/mul, Softplus as
    mul/softplus/div; the dynamo one Gelu, Mish ops and Softplus's threshold as a Where)."""
    net = _net(act, 2)
    p = tmp_path / f"m.{form}"
    if form == "pt2":
        torch.export.save(_quiet(torch.export.export, net, (torch.zeros(3, 3),)), p)
    elif form == "script":
        _quiet(torch.jit.script(net).save, str(p))
    elif form == "onnx_legacy":
        p = p.with_suffix(".onnx")
        _quiet(torch.onnx.export, net, (torch.zeros(1, 3),), str(p), dynamo=False, input_names=["x"],
               dynamic_axes={"x": {0: "N"}})  # fmt: skip
    else:
        p = p.with_suffix(".onnx")
        _quiet(torch.onnx.export, net, (torch.zeros(3, 3),), str(p), dynamo=True, verbose=False,
               dynamic_shapes=({0: torch.export.Dim("N")},))  # fmt: skip
    original = _ort_original(p) if p.suffix == ".onnx" else _torch_original(net)
    _within_bound(p, _spec(tmp_path), original)


def _graph(kind: str, seed: int):
    """Gemm(3 -> 8) -> the activation as `kind` writes it -> Gemm(8 -> 1), built with onnx.helper."""
    from onnx import TensorProto, helper, numpy_helper

    rng = np.random.default_rng(seed)
    w1, b1 = rng.normal(0, 3, (8, 3)).astype(np.float32), rng.normal(size=8).astype(np.float32)
    w2, b2 = rng.normal(size=(1, 8)).astype(np.float32), rng.normal(size=1).astype(np.float32)
    inits = {"w1": w1, "b1": b1, "w2": w2, "b2": b2}
    nodes = [helper.make_node("Gemm", ["x", "w1", "b1"], ["h"], transB=1)]
    n = helper.make_node
    opset = 18
    if kind == "Gelu":
        nodes.append(n("Gelu", ["h"], ["a"]))
        opset = 20
    elif kind == "Gelu_tanh":
        nodes.append(n("Gelu", ["h"], ["a"], approximate="tanh"))
        opset = 20
    elif kind == "erf_mul":  # jax2onnx / tf2onnx: x * (1 / sqrt 2), 0.5 * x first
        inits |= {"r2": np.float32(1 / math.sqrt(2)), "one": np.float32(1.0), "half": np.float32(0.5)}
        nodes += [n("Mul", ["h", "r2"], ["s"]), n("Erf", ["s"], ["e"]), n("Add", ["one", "e"], ["e1"])]
        nodes += [n("Mul", ["half", "h"], ["hh"]), n("Mul", ["hh", "e1"], ["a"])]
    elif kind == "erf_div":  # torch's legacy exporter: x / sqrt 2, x * (1 + erf), * 0.5 last
        inits |= {"s2": np.float32(math.sqrt(2)), "one": np.float32(1.0), "half": np.float32(0.5)}
        nodes += [n("Div", ["h", "s2"], ["s"]), n("Erf", ["s"], ["e"]), n("Add", ["e", "one"], ["e1"])]
        nodes += [n("Mul", ["h", "e1"], ["m"]), n("Mul", ["m", "half"], ["a"])]
    elif kind == "swish":
        nodes += [n("Sigmoid", ["h"], ["s"]), n("Mul", ["s", "h"], ["a"])]
    elif kind == "HardSigmoid":  # ONNX's defaults alpha 0.2, beta 0.5
        nodes.append(n("HardSigmoid", ["h"], ["a"]))
    elif kind == "PRelu":
        inits["slope"] = np.linspace(-0.6, 0.8, 8).astype(np.float32)
        nodes.append(n("PRelu", ["h", "slope"], ["a"]))
    elif kind == "Elu":
        nodes.append(n("Elu", ["h"], ["a"], alpha=0.5))
    else:  # Selu, Softplus, Mish, HardSwish with their defaults
        nodes.append(n(kind, ["h"], ["a"]))
    nodes.append(n("Gemm", ["a", "w2", "b2"], ["y"], transB=1))
    g = helper.make_graph(
        nodes,
        kind,
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, ["N", 3])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, ["N", 1])],
        [numpy_helper.from_array(np.asarray(v), k) for k, v in inits.items()],
    )
    return helper.make_model(g, opset_imports=[helper.make_opsetid("", opset)], ir_version=9)


GRAPHS = ["Gelu", "Gelu_tanh", "erf_mul", "erf_div", "swish", "HardSigmoid", "PRelu", "Elu", "Selu",
          "Softplus", "Mish", "HardSwish"]  # fmt: skip
FAST_GRAPHS = ("erf_mul", "HardSigmoid", "PRelu")


@pytest.mark.parametrize(
    "kind", [k if k in FAST_GRAPHS else pytest.param(k, marks=pytest.mark.slow) for k in GRAPHS]
)
def test_onnx_graph_within_bound(kind, tmp_path):
    """Hand-built graphs (the ops with ONNX's default attributes, the erf patterns converters write, x *
    sigmoid(x), per-channel PRelu slopes): within the bound of onnxruntime on the original graph."""
    import onnx

    p = tmp_path / f"{kind}.onnx"
    onnx.save(_graph(kind, 5), str(p))
    _within_bound(p, _spec(tmp_path), _ort_original(p))


def test_erf_pattern_read_as_gelu_unknown_region_refused(tmp_path):
    """The erf pattern is read as GELU (the chain names it); a region computing something else (x * tanh(x))
    is left as it is and refused by the chain reader, one line, exit 2."""
    import onnx

    from seagen.errors import UserError
    from seagen.frontends import read_onnx

    onnx.save(_graph("erf_div", 6), str(tmp_path / "g.onnx"))
    net = read_onnx(tmp_path / "g.onnx")
    assert [lay.activation for lay in net.layers] == ["gelu", "linear"]
    m = _graph("swish", 6)
    for node in m.graph.node:
        if node.op_type == "Sigmoid":
            node.op_type = "Tanh"
    onnx.save(m, str(tmp_path / "t.onnx"))
    with pytest.raises(UserError, match="computed inputs"):
        read_onnx(tmp_path / "t.onnx")
