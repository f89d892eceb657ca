"""Float MLP -> quantized MLP: Q formats, accumulator widths and the error bound from interval analysis."""

from __future__ import annotations

import dataclasses

import numpy as np

from seagen.errors import UserError
from seagen.ir import QMLP, FloatLayer, FloatMLP, QInput, QLayer, QTable
from seagen.quant.activation import ADDED, format_magnitude, quantize_act
from seagen.quant.bound import mlp_error_bound
from seagen.quant.interval import acc_interval
from seagen.quant.qformat import frac_for, quantize, widened
from seagen.runtime.activations import TABLE_OUT_FRAC, make_table
from seagen.runtime.features import frac_cap, source_of
from seagen.runtime.fixed import rshift_rne

INT16_MAX = 2**15 - 1
ACC32_LIMIT = 2**31 - 1


def quantize_inputs(model: FloatMLP) -> tuple[QInput, ...]:
    """Per-input Q formats from the widened calibrated box; int16 bounds of the box."""
    out = []
    for s in model.inputs:
        lo, hi = widened(s.lo, s.hi)
        f = frac_for(max(abs(lo), abs(hi)), INT16_MAX)
        if (cap := frac_cap(s.name)) is not None:
            f = min(f, cap)  # no finer than the pipeline computes it
        lo_q, hi_q = int(quantize(lo, f)), int(quantize(hi, f))
        if not (-(2**15) <= lo_q <= hi_q <= INT16_MAX):
            raise UserError(f"input '{s.name}': range [{s.lo}, {s.hi}] cannot be represented in int16")
        out.append(QInput(s, f, lo_q, hi_q, source_of(s.name, f)))
    return tuple(out)


def _out_frac(mn: np.ndarray, mx: np.ndarray, acc_frac: int, layer: FloatLayer) -> int:
    """Largest output format with no saturation over the box (acc_frac >= result >= acc_frac - 62)."""
    activation = layer.activation
    hi = max(max(mx), 0) if activation == "relu" else max(max(abs(mn)), max(abs(mx)))
    if activation in ADDED:
        hi = format_magnitude(layer, int(hi), acc_frac)
    if activation in ("tanh", "sigmoid"):
        hi = min(hi, 8 << acc_frac)  # beyond +-8 the table saturates anyway
    f = acc_frac
    while f > acc_frac - 62 and int(rshift_rne(int(hi), acc_frac - f)) > INT16_MAX:
        f -= 1
    return f


def quantize_layer(
    layer: FloatLayer, w_eff: np.ndarray, in_frac: int, lo: np.ndarray, hi: np.ndarray, wmax: int, index: int
) -> tuple[QLayer, QTable | None]:
    """One layer: weight format, integer weights and bias, accumulator width, output format, activation."""
    w_frac = frac_for(float(np.max(np.abs(w_eff))), wmax)
    w_q = quantize(w_eff, w_frac)
    if int(np.max(np.abs(w_q))) > wmax:
        raise UserError(
            f"layer {index}: weights up to {float(np.max(np.abs(w_eff))):.3g} do not fit "
            f"int{wmax.bit_length() + 1} even at Q{w_frac} (with the normalisation folded in)"
        )
    acc_frac = w_frac + in_frac
    b_q = quantize(layer.bias, acc_frac)
    mn, mx, per_neuron = acc_interval(w_q, b_q, lo, hi)
    worst = max(per_neuron)
    if worst >= 2**62:
        raise UserError(
            f"layer {index}: accumulator bound 2^{int(worst).bit_length()} exceeds int64 (weights and bias "
            "too large for the input box, with the normalisation folded in)"
        )
    out_frac = _out_frac(mn, mx, acc_frac, layer)
    shift = acc_frac - out_frac
    # the interval end points fit int64 (|acc| < 2^62 was checked above)
    y_lo = np.maximum(rshift_rne(mn.astype(np.int64), shift), -(2**15))
    y_hi = np.minimum(rshift_rne(mx.astype(np.int64), shift), INT16_MAX)
    if layer.activation in ADDED:  # seagen/quant/activation.py: its own output format and exact interval
        params, table, act_frac, y_lo, y_hi = quantize_act(layer, out_frac, y_lo, y_hi, index)
    else:
        params, table = _activation(layer, out_frac, index)
        y_lo, y_hi = _act_bounds(layer.activation, params, table, y_lo, y_hi)
        act_frac = out_frac if table is None else TABLE_OUT_FRAC
    q = QLayer(
        w_q,
        b_q,
        w_frac,
        in_frac,
        act_frac,
        shift,
        32 if worst <= ACC32_LIMIT else 64,
        layer.activation,
        params,
        out_frac,
        y_lo,
        y_hi,
    )
    return q, table


def _activation(layer: FloatLayer, pre_frac: int, index: int) -> tuple[tuple[int, ...], QTable | None]:
    if layer.activation == "leaky_relu":
        return (int(quantize(layer.alpha, 15)),), None
    if layer.activation == "hardtanh":
        # clip before rounding: an unbounded side (+-inf, a one-sided Clip) saturates instead of overflowing
        lo = int(quantize(np.clip(layer.lo * 2.0**pre_frac, -(2**15), INT16_MAX), 0))
        hi = int(quantize(np.clip(layer.hi * 2.0**pre_frac, -(2**15), INT16_MAX), 0))
        return (lo, hi), None
    if layer.activation in ("tanh", "sigmoid"):
        return (), make_table(layer.activation, pre_frac, f"l{index}_{layer.activation}")
    return (), None


def _act_bounds(act: str, params: tuple[int, ...], table: QTable | None, lo: np.ndarray, hi: np.ndarray):
    if act == "relu":
        return np.maximum(lo, 0), np.maximum(hi, 0)
    if act == "leaky_relu" and params[0] >= 0:
        return np.minimum(lo, 0) * params[0] // 2**15 - 1, hi
    if act == "leaky_relu":  # a negative slope maps the negative side to [0, alpha * lo]
        top = -((-np.minimum(lo, 0) * params[0]) // 2**15) + 1
        return np.zeros_like(lo), np.minimum(np.maximum(hi, top), INT16_MAX)
    if act == "hardtanh":
        return np.clip(lo, params[0], params[1]), np.clip(hi, params[0], params[1])
    if table is not None:
        return np.full_like(lo, int(table.values.min())), np.full_like(hi, int(table.values.max()))
    return lo, hi


def quantize_mlp(model: FloatMLP, weight_bits: int = 16) -> QMLP:
    """The whole network; raises UserError when a range cannot be represented."""
    wmax = 2 ** (weight_bits - 1) - 1
    inputs = quantize_inputs(model)
    lo = np.array([i.lo_q for i in inputs], dtype=np.int64)
    hi = np.array([i.hi_q for i in inputs], dtype=np.int64)
    scale = np.array([2.0**-i.frac for i in inputs])
    layers, tables = [], []
    in_frac = 0
    for k, layer in enumerate(model.layers):
        w_eff = layer.weight * scale[None, :] if k == 0 else layer.weight
        q, table = quantize_layer(layer, w_eff, in_frac, lo, hi, wmax, k)
        layers.append(q)
        if table is not None:
            tables.append(table)
        lo, hi = q.y_lo, q.y_hi
        in_frac = q.out_frac
    qm = QMLP(
        inputs,
        model.output,
        layers[-1].out_frac,
        tuple(layers),
        tuple(tables),
        weight_bits=weight_bits,
        task=model.task,
    )
    return dataclasses.replace(qm, error_bound=mlp_error_bound(model, qm))
