"""The oracle margin of a float16/bfloat16 original comes from its own rounding on the calibrated box (its
graph run in float16 against the same graph in float32), stated beside the bound: within 10x the rounding
the test measures itself, and tight enough to catch a planted 1 % weight change. ~3 s."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from seagen.frontends import read_onnx
from seagen.frontends.load import load_with_original
from seagen.frontends.margin import MEASURED_SAFETY, forward_margin
from seagen.quant.model import quantize
from seagen.reference.oracle import box_points, compare_original
from tests import table_models as T

MEAN, STD = np.array(T.MEAN), np.array(T.STD)


def _graph(w2_scale: float = 1.0, dtype=np.float16):
    """Gemm-Tanh-Gemm with float16 weights (W2 scaled by `w2_scale` before the cast), in `dtype`."""
    from onnx import helper

    w = {k: np.asarray(v, np.float16) for k, v in T.weights(7).items()}
    w["W2"] = np.asarray(w["W2"].astype(float) * w2_scale, np.float16)
    g1 = helper.make_node("Gemm", ["x", "W1", "B1"], ["h"], transB=1)
    g2 = helper.make_node("Gemm", ["a", "W2", "B2"], ["y"], transB=1)
    return T.onnx_model([g1, helper.make_node("Tanh", ["h"], ["a"]), g2], w, dtype=dtype)


def _physical(run):
    """A network on normalised inputs as a function of physical inputs, in output units."""
    return lambda x: run((np.asarray(x) - MEAN) / STD) * T.OUT_STD + T.OUT_MEAN


def _measured_rounding(f16, f32, n: int = 20000) -> float:
    """The test's own measure: max |float16 run - float32 run| on random points of the calibrated box."""
    lo, hi = np.array(T.RANGE).T
    x = lo + np.random.default_rng(11).random((n, T.N_IN)) * (hi - lo)
    return float(np.max(np.abs(f16(x) - f32(x))))


def test_float16_onnx_margin_within_10x_its_rounding_and_stated(tmp_path):
    """onnxruntime's float16 graph: margin between its rounding and 10x it; the note states both."""
    spec = str(T.spec_file(tmp_path))
    p = T.save_onnx(_graph(), tmp_path / "f16.onnx")
    loaded = load_with_original(str(p), spec)
    p32 = T.save_onnx(_graph(dtype=np.float32), tmp_path / "f32.onnx")  # the same float16 values, in float32
    rounding = _measured_rounding(_physical(T.ort_original(p, np.float16)), _physical(T.ort_original(p32)))
    assert 0 < rounding <= loaded.margin <= 10 * rounding, (rounding, loaded.margin)
    assert any(
        "oracle margin" in n and f"{MEASURED_SAFETY:g} x its largest rounding" in n for n in loaded.notes
    )


def test_float16_torch_margin_within_10x_its_rounding(tmp_path):
    """A float16 torch module: the same, against the test's float32 copy of it."""
    m = T.seq(nn.ReLU(), seed=5).half()
    torch.save(m, tmp_path / "half.pt")
    loaded = load_with_original(str(tmp_path / "half.pt"), str(T.spec_file(tmp_path)))
    m32 = T.seq(nn.ReLU(), seed=5).half().float()
    rounding = _measured_rounding(_physical(_cast_run(m)), _physical(T.torch_original(m32)))
    assert 0 < rounding <= loaded.margin <= 10 * rounding, (rounding, loaded.margin)


def _cast_run(m: nn.Module):
    """A float16 module's own forward on inputs cast to float16."""

    def run(x):
        with torch.no_grad():
            return m(torch.from_numpy(np.asarray(x, np.float32)).half()).double().numpy()[:, 0]

    return run


def test_planted_one_percent_weight_change_is_caught(tmp_path):
    """The integer model of a float16 graph whose last layer's weights were changed by 1 % disagrees with the
    original beyond bound + margin (the analytic float16 margin this replaces let it through); the
    unchanged model agrees."""
    spec = str(T.spec_file(tmp_path))
    loaded = load_with_original(str(T.save_onnx(_graph(), tmp_path / "f16.onnx")), spec)
    planted = load_with_original(str(T.save_onnx(_graph(1.01), tmp_path / "planted.onnx")), spec)
    qm, bad = quantize(loaded.model), quantize(planted.model)
    x = box_points(qm)
    assert compare_original("honest", qm, loaded.original, x, loaded.margin).ok
    rep = compare_original("planted", bad, loaded.original, x, loaded.margin)
    assert not rep.ok, rep.line()
    xmax = np.max(np.abs((np.array(T.RANGE).T - MEAN) / STD), axis=0)
    old = forward_margin(read_onnx(tmp_path / "f16.onnx").layers, xmax, "float16") * T.OUT_STD
    assert compare_original("planted, analytic margin", bad, loaded.original, x, old).ok


def test_float32_margin_passes_each_smooth_activation_through_its_slope():
    """A float32 network of each smooth activation whose slope exceeds 1 somewhere (SELU 1.76 below zero,
    GELU 1.13, Softplus's log 2 at zero): the stated margin without its safety factor still holds the float32
    forward's measured difference from float64 on the box's corners and a sample, and for SELU it is larger
    than the same weights under ReLU (the error passes the activation's Lipschitz constant)."""
    from seagen.frontends.margin import SAFETY
    from seagen.ir import FloatLayer
    from seagen.runtime.activations import SELU, act_float

    rng = np.random.default_rng(3)
    w1, b1 = rng.normal(0, 2.0, (32, 4)), rng.normal(0, 1.0, 32)
    w2, b2 = rng.normal(0, 1.0, (1, 32)), rng.normal(0, 1.0, 1)
    xmax = np.full(4, 3.0)
    corners = np.array(np.meshgrid(*[[-3.0, 3.0]] * 4)).reshape(4, -1).T
    x = np.vstack([corners, rng.uniform(-3, 3, (4000, 4))])
    params = {"selu": SELU, "gelu": (), "softplus": (1.0, 20.0), "elu": (1.5,), "mish": (), "silu": ()}
    margins = {}
    for act, p in params.items():
        layers = [FloatLayer(w1, b1, act, params=p), FloatLayer(w2, b2)]
        margins[act] = forward_margin(layers, xmax, "float32")

        def run(dtype, p=p, act=act):
            z = (x.astype(dtype) @ w1.T.astype(dtype) + b1.astype(dtype)).astype(dtype)
            h = act_float(act, p, z.astype(np.float64)).astype(dtype)
            return (h @ w2.T.astype(dtype) + b2.astype(dtype)).astype(np.float64)

        measured = float(np.max(np.abs(run(np.float32) - run(np.float64))))
        assert 0 < measured <= margins[act] / SAFETY, (act, measured, margins[act])
    relu = forward_margin([FloatLayer(w1, b1, "relu"), FloatLayer(w2, b2)], xmax, "float32")
    assert margins["selu"] > relu
