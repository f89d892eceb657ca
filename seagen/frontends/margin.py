"""A stated margin for the original's own rounding: a forward-error bound of its layers in its float type."""

from __future__ import annotations

import numpy as np

from seagen.errors import UserError
from seagen.ir import FloatLayer

UNIT_ROUNDOFF = {"float64": 2.0**-53, "float32": 2.0**-24, "float16": 2.0**-11, "bfloat16": 2.0**-8}
U32 = UNIT_ROUNDOFF["float32"]
SAFETY = 4.0  # covers the folded elementwise ops (BatchNorm, constant Add/Mul, casts) each rounding once


def float32_margin(layers: list[FloatLayer], xmax: np.ndarray) -> float:
    """forward_margin for a float32 original."""
    return forward_margin(layers, xmax, "float32")


def forward_margin(layers: list[FloatLayer], xmax: np.ndarray, dtype: str, where: str = "model") -> float:
    """Bound on |forward in `dtype` - exact| for inputs with |x| <= xmax (the network's own inputs).

    Per layer (Higham): |fl(Wx + b) - (Wx + b)| <= gamma_{n+1} (|W| |x| + |b|), gamma_k = k u / (1 - k u);
    errors already made propagate through |W| (activations are 1-Lipschitz); the input cast adds u |x|.
    u is the unit roundoff of `dtype` (float16, bfloat16, float32, float64). The result is multiplied by
    SAFETY.
    """
    u = UNIT_ROUNDOFF[dtype]
    mag = np.asarray(xmax, dtype=float)
    err = u * mag
    for lay in layers:
        n = lay.weight.shape[1] + 1
        if n * u >= 0.5:
            raise UserError(
                f"{where}: a {dtype} layer with {n - 1} inputs: its own rounding has no useful bound "
                "(the oracle cannot compare it); save the model in float32"
            )
        gamma = n * u / (1 - n * u)
        w = np.abs(lay.weight)
        z = w @ mag + np.abs(lay.bias)
        err = w @ err + gamma * z + u * z  # + one rounding of the activation's result
        mag = _act_mag(lay, z)
    return SAFETY * float(np.max(err))


def _act_mag(lay: FloatLayer, z: np.ndarray) -> np.ndarray:
    """Largest |activation output| given |pre-activation| <= z."""
    if lay.activation in ("tanh", "sigmoid"):
        return np.ones_like(z)
    if lay.activation == "hardtanh":
        lim = max(abs(lay.lo), abs(lay.hi))
        return np.minimum(z, lim) if np.isfinite(lim) else z
    return z
