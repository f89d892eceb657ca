"""A stated margin for an original that runs in float32: a forward-error bound of its layers."""

from __future__ import annotations

import numpy as np

from seagen.ir import FloatLayer

U32 = 2.0**-24  # float32 unit roundoff
SAFETY = 4.0  # covers the folded elementwise ops (BatchNorm, constant Add/Mul, casts) each rounding once


def float32_margin(layers: list[FloatLayer], xmax: np.ndarray) -> float:
    """Bound on |float32 forward - exact| for inputs with |x| <= xmax (the network's own inputs).

    Per layer (Higham): |fl(Wx + b) - (Wx + b)| <= gamma_{n+1} (|W| |x| + |b|), gamma_k = k u / (1 - k u);
    errors already made propagate through |W| (activations are 1-Lipschitz); the input cast adds u |x|.
    The result is multiplied by SAFETY.
    """
    mag = np.asarray(xmax, dtype=float)
    err = U32 * mag
    for lay in layers:
        n = lay.weight.shape[1] + 1
        gamma = n * U32 / (1 - n * U32)
        w = np.abs(lay.weight)
        z = w @ mag + np.abs(lay.bias)
        err = w @ err + gamma * z + U32 * z  # + one rounding of the activation's result
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
