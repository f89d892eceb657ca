"""Small frozen dataclasses between fitting and rendering: float models and quantized models."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

ACTIVATIONS = (
    *("linear", "relu", "leaky_relu", "hardtanh", "tanh", "sigmoid"),
    *("elu", "selu", "softplus", "gelu", "gelu_tanh", "mish", "silu", "hardsigmoid", "hardswish", "prelu"),
)


@dataclass(frozen=True, eq=False)
class Signal:
    """One model input or output: name, unit and the calibrated range in physical units."""

    name: str
    unit: str
    lo: float
    hi: float


@dataclass(frozen=True, eq=False)
class FloatLayer:
    """y = act(W x + b) in floating point; W has shape (out, in)."""

    weight: np.ndarray
    bias: np.ndarray
    activation: str = "linear"
    alpha: float = 0.01  # leaky_relu slope
    lo: float = -1.0  # hardtanh limits
    hi: float = 1.0
    # elu (alpha,), selu (alpha, scale), softplus (beta, threshold), hardsigmoid (alpha, beta), prelu: the
    # per-channel slopes (seagen/runtime/activations.py act_float)
    params: tuple[float, ...] = ()


@dataclass(frozen=True, eq=False)
class FloatMLP:
    """An MLP on physical-unit inputs (normalization already folded into the first and last layers)."""

    inputs: tuple[Signal, ...]
    output: Signal
    layers: tuple[FloatLayer, ...]
    task: str = "calibration"
    meta: dict = field(default_factory=dict)


def poly2(
    powers: tuple[tuple[int, int], ...], coef, a: np.ndarray | float, b: np.ndarray | float
) -> np.ndarray:
    """sum of c * a**i * b**j in float64: the one evaluation of a surface fit (fit, quant, the oracle)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return sum((c * a**i * b**j for (i, j), c in zip(powers, coef, strict=True)), np.zeros_like(a))


@dataclass(frozen=True, eq=False)
class FloatSF:
    """A 2-input polynomial: sum coef[k] * a^powers[k][0] * b^powers[k][1], physical units."""

    inputs: tuple[Signal, Signal]
    output: Signal
    powers: tuple[tuple[int, int], ...]
    coef: tuple[float, ...]
    task: str = "calibration"
    meta: dict = field(default_factory=dict)


FloatModel = FloatMLP | FloatSF


@dataclass(frozen=True)
class FeatureSource:
    """Where the feature pipeline (c_runtime/sea_features.h) takes a model input from.

    kind: SEA_FEAT_BASE / _D / _DD / _ANGLE / _EXTERNAL; index: the base signal (or external argument);
    from_frac: the format the pipeline computes it in (the value is converted to the input's format).
    """

    kind: int
    index: int
    from_frac: int


@dataclass(frozen=True, eq=False)
class QInput:
    """A quantized input feature: int16 value = round(x * 2^frac), clamped to [lo_q, hi_q]."""

    signal: Signal
    frac: int
    lo_q: int
    hi_q: int
    source: FeatureSource | None  # how NAME_step computes it from raw counts (None: it cannot)


@dataclass(frozen=True, eq=False)
class QLayer:
    """acc = W_q x_q + b_q (acc_bits wide); y_q = act(sat16(rshift_rne(acc, shift))), y in Q(out_frac)."""

    w_q: np.ndarray  # int64 values in int16 (or int8) range, shape (out, in)
    b_q: np.ndarray  # int64, in the accumulator's format
    w_frac: int
    in_frac: int  # 0 for the first layer: its weights already carry each input's scale
    out_frac: int
    shift: int
    acc_bits: int  # 32 or 64, proven by interval analysis
    activation: str
    # leaky: (alpha_q15,); hardtanh: (lo_q, hi_q); smooth: (s_q14,); hardsigmoid and hardswish: (alpha_q,
    # beta_q30); prelu: alpha_q15 per channel
    act_params: tuple[int, ...] = ()
    pre_frac: int = 0  # format of the shifted accumulator before the activation (= out_frac but for tables)
    y_lo: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # proven output interval
    y_hi: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # per neuron, int16 units


@dataclass(frozen=True, eq=False)
class QTable:
    """A shared activation table: y_q = table[clamp((x_q >> in_shift) - offset, 0, len-1)]."""

    name: str
    values: np.ndarray  # int64 values in int16 range
    in_frac: int
    out_frac: int
    in_shift: int
    offset: int


@dataclass(frozen=True, eq=False)
class QHorner:
    """One Horner step on int32 registers (floor shifts, c_runtime/README.md item 7).

    var < 0: r[dst] = coef_q (a load). Otherwise r[dst] = sat32(floor(x[var] * r[src] / 2^shift) + A),
    A = coef_q (in r[dst]'s format), or r[add_reg] * 2^align (align >= 0) or floor(r[add_reg] / 2^-align).
    frac is the Q format of r[dst].
    """

    dst: int
    var: int
    src: int
    add_reg: int
    coef_q: int
    align: int
    shift: int
    frac: int


@dataclass(frozen=True, eq=False)
class QMLP:
    """A quantized MLP: inputs, dense layers (with their activation tables), the output."""

    inputs: tuple[QInput, ...]
    output: Signal
    out_frac: int
    layers: tuple[QLayer, ...]
    tables: tuple[QTable, ...] = ()
    weight_bits: int = 16
    task: str = "calibration"
    error_bound: float = float("nan")  # proven worst case |fixed - float| over the box, output units
    meta: dict = field(default_factory=dict)
    kind = "mlp"  # class constant, for summaries


@dataclass(frozen=True, eq=False)
class QSF:
    """A quantized surface fit: inputs, the straight-line Horner program on int32 registers, the output."""

    inputs: tuple[QInput, ...]
    output: Signal
    out_frac: int
    horner: tuple[QHorner, ...]
    out_shift: int  # final register -> int16 output shift
    n_regs: int  # registers used by the Horner program
    task: str = "calibration"
    error_bound: float = float("nan")
    meta: dict = field(default_factory=dict)
    kind = "sf"


QModel = QMLP | QSF
