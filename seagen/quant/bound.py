"""Proven worst-case |fixed - float| over the calibrated box: error radii propagated layer by layer, or
(tighter, for the activations it bounds) symbolic per-neuron intervals on sub-boxes (seagen.quant.affine)."""

from __future__ import annotations

import numpy as np

from seagen.ir import QMLP, FloatMLP
from seagen.quant.activation import ADDED, act_error
from seagen.quant.affine import affine_error_bound
from seagen.quant.qformat import widened
from seagen.runtime.activations import table_error


def mlp_error_bound(model: FloatMLP, qm: QMLP) -> float:
    """Bound on |infer(quantize(x)) * 2^-out_frac - float(x)| for every x in the widened box (output units).

    Per layer: e_z = sum|W - W_hat| |x|max + sum|W_hat| e_x + |b - b_hat| + half an output LSB; ReLU and
    Hardtanh are 1-Lipschitz, LeakyReLU adds its slope's quantization and a second rounding, tanh/sigmoid
    add the table error (Lipschitz 1 and 1/4). The smaller of this and seagen.quant.affine's bound (both
    are proven; the affine one follows each neuron's reachable range over sub-boxes of the box).
    """
    boxes = [widened(s.lo, s.hi) for s in model.inputs]
    xmax = np.array([max(abs(a), abs(b)) for a, b in boxes])
    e = np.array([2.0 ** -(i.frac + 1) for i in qm.inputs])
    scale = np.array([2.0**i.frac for i in qm.inputs])
    tables = {t.name: t for t in qm.tables}
    for k, (fl, q) in enumerate(zip(model.layers, qm.layers, strict=True)):
        w_hat = q.w_q * 2.0**-q.w_frac * (scale[None, :] if k == 0 else 1.0)
        b_hat = q.b_q * 2.0 ** -(q.w_frac + q.in_frac)
        half = 2.0 ** -(q.pre_frac + 1)
        ez = np.abs(fl.weight - w_hat) @ xmax + np.abs(w_hat) @ e + np.abs(fl.bias - b_hat) + half
        zmax = np.abs(w_hat) @ (xmax + e) + np.abs(b_hat)
        if fl.activation in ADDED:  # smooth and piecewise-linear ones: seagen/quant/activation.py
            e = act_error(fl, q, tables.get(f"l{k}_{fl.activation}"), ez, zmax)
        else:
            e = _through_activation(fl.activation, q, ez, zmax, fl.alpha, half, tables, k)
        out_max = np.maximum(np.abs(q.y_lo), np.abs(q.y_hi)) * 2.0**-q.out_frac
        xmax = out_max + e
    return min(float(np.max(e)), affine_error_bound(model, qm))


def _through_activation(
    act: str, q, ez: np.ndarray, zmax: np.ndarray, alpha: float, half: float, tables: dict, k: int
) -> np.ndarray:
    if act == "leaky_relu":
        return ez + abs(alpha - q.act_params[0] / 2**15) * zmax + half
    if act in ("tanh", "sigmoid"):
        t = tables[f"l{k}_{act}"]
        return (1.0 if act == "tanh" else 0.25) * ez + table_error(t, act)
    return ez
