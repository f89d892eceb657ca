"""The float model on physical-unit inputs (float64 numpy): what the fixed-point program approximates."""

from __future__ import annotations

import numpy as np

from seagen.ir import FloatMLP, FloatModel, FloatSF
from seagen.quant.activation import ADDED, params_of
from seagen.quant.sf import float_sf
from seagen.runtime.activations import act_float


def _act(name: str, z: np.ndarray, alpha: float, lo: float, hi: float) -> np.ndarray:
    if name == "relu":
        return np.maximum(z, 0.0)
    if name == "leaky_relu":
        return np.where(z >= 0, z, alpha * z)
    if name == "hardtanh":
        return np.clip(z, lo, hi)
    if name == "tanh":
        return np.tanh(z)
    if name == "sigmoid":
        return 1.0 / (1.0 + np.exp(-z))
    return z


def predict(model: FloatModel, x: np.ndarray) -> np.ndarray:
    """Output (N,) for physical inputs (N, n_in)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    if isinstance(model, FloatSF):
        return float_sf(model, x)
    assert isinstance(model, FloatMLP)
    for layer in model.layers:
        z = x @ layer.weight.T + layer.bias
        if layer.activation in ADDED:
            x = act_float(layer.activation, params_of(layer), z)
        else:
            x = _act(layer.activation, z, layer.alpha, layer.lo, layer.hi)
    return x[:, 0]


def quantize_features(qm, x: np.ndarray) -> np.ndarray:
    """Physical features (N, n_in) -> int16 model inputs: round(x * 2^frac), saturated to int16."""
    return quantize_columns(qm.inputs, x)


def quantize_columns(qins, x: np.ndarray) -> np.ndarray:
    """Physical columns (N, len(qins)) -> int16 values of those QInputs: round(x * 2^frac), saturated."""
    fr = np.array([2.0**i.frac for i in qins])
    return np.clip(np.rint(np.asarray(x, dtype=float) * fr[None, :]), -(2**15), 2**15 - 1).astype(np.int64)
