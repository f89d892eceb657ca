"""A stated margin for the original's own rounding: a forward-error bound of its layers in its float type, or
for a float16/bfloat16 original its rounding measured against its float32 twin on the calibrated box."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from seagen.errors import UserError
from seagen.ir import FloatLayer
from seagen.quant.activation import ADDED, lipschitz
from seagen.runtime import activations as A

UNIT_ROUNDOFF = {"float64": 2.0**-53, "float32": 2.0**-24, "float16": 2.0**-11, "bfloat16": 2.0**-8}
U32 = UNIT_ROUNDOFF["float32"]
SAFETY = 4.0  # covers the folded elementwise ops (BatchNorm, constant Add/Mul, casts) each rounding once
MEASURED_SAFETY = 3.0  # margin = this x the largest float16-vs-float32 difference seen on the box sample
N_SAMPLE = 4096  # uniform points of the box (besides its corners) the rounding is measured on
MAX_CORNERS = 1024


def float32_margin(layers: list[FloatLayer], xmax: np.ndarray) -> float:
    """forward_margin for a float32 original."""
    return forward_margin(layers, xmax, "float32")


def forward_margin(layers: list[FloatLayer], xmax: np.ndarray, dtype: str, where: str = "model") -> float:
    """Bound on |forward in `dtype` - exact| for inputs with |x| <= xmax (the network's own inputs).

    Per layer (Higham): |fl(Wx + b) - (Wx + b)| <= gamma_{n+1} (|W| |x| + |b|), gamma_k = k u / (1 - k u);
    errors already made propagate through |W| and each activation's Lipschitz constant (_act_lip_mag); the
    input cast adds u |x|.
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
        lip, out = _act_lip_mag(lay, z)
        # the error passes the activation through its Lipschitz constant; + one rounding of its result
        err = lip * (w @ err + gamma * z) + u * (np.maximum(z, out) if lay.activation in ADDED else z)
        mag = out
    return SAFETY * float(np.max(err))


def _act_lip_mag(lay: FloatLayer, z: np.ndarray) -> tuple[float | np.ndarray, np.ndarray]:
    """(Lipschitz constant, largest |output|) of the layer's activation given |pre-activation| <= z: 1 and
    _act_mag for the piecewise-linear and saturating ones; the smooth ones (SELU's slope 1.05 and its
    1.76 below zero, Softplus's log 2 at zero) their measured sup |f'| and s z + sup |g|."""
    act, p = lay.activation, tuple(lay.params)
    if act not in ADDED:
        return 1.0, _act_mag(lay, z)
    lip = lipschitz(lay, z.shape)
    if act in A.SMOOTH:
        return lip, A.slope(act, p) * z + A.shape_of(act, p).gmax
    if act == "hardsigmoid":
        return lip, np.ones_like(z)
    return lip, (z if act == "hardswish" else lip * z)  # |x h(x)| <= |x|; PReLU: max(1, |a|) |x|


def _act_mag(lay: FloatLayer, z: np.ndarray) -> np.ndarray:
    """Largest |activation output| given |pre-activation| <= z."""
    if lay.activation in ("tanh", "sigmoid"):
        return np.ones_like(z)
    if lay.activation == "hardtanh":
        lim = max(abs(lay.lo), abs(lay.hi))
        return np.minimum(z, lim) if np.isfinite(lim) else z
    return z


@dataclass(frozen=True)
class Measured:
    """A low-precision original's rounding measured on the box: the margin and what it rests on."""

    margin: float  # in the network's own output units
    measured: float  # max |original - float32 twin| over the sample
    points: int

    def note(self, dtype: str, scale: float, unit: str) -> str:
        """One line: the margin beside the rounding it was derived from."""
        return (
            f"note: {dtype} original: oracle margin {self.margin * scale:.3g} {unit} = "
            f"{MEASURED_SAFETY:g} x its largest rounding {self.measured * scale:.3g} {unit} (the graph in "
            f"{dtype} against it in float32 on {self.points} box points: corners and a uniform sample) + "
            "the float32 twin's own bound"
        )


def box_sample(lo: np.ndarray, hi: np.ndarray, n: int = N_SAMPLE, seed: int = 0) -> np.ndarray:
    """The box's corners (all up to MAX_CORNERS, else random ones), its centre and n uniform points."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    k = len(lo)
    rng = np.random.default_rng(seed)
    if 2**k <= MAX_CORNERS:
        corners = np.array(list(itertools.product((0.0, 1.0), repeat=k)))
    else:
        corners = rng.integers(0, 2, (MAX_CORNERS, k)).astype(float)
    unit = np.vstack([corners, np.full((1, k), 0.5), rng.random((n, k))])
    return lo + unit * (hi - lo)


def rounding_margin(
    run: Callable[[np.ndarray], np.ndarray],
    wide: Callable[[np.ndarray], np.ndarray],
    lo: np.ndarray,
    hi: np.ndarray,
    layers: list[FloatLayer],
    whole: bool = False,
) -> Measured | None:
    """The margin for a float16/bfloat16 original from its own rounding on the box lo..hi (its own inputs):
    MEASURED_SAFETY x max |run(x) - wide(x)| over box_sample, plus the float32 twin's forward bound.

    Equal outputs everywhere: with `whole` (the twin widens every tensor and cast, as for an ONNX graph;
    onnxruntime runs float16 ops on the CPU in float32) the original computes as its twin and the margin is
    the twin's; otherwise (a module whose float16 casts may sit in its code, not in its tensors) None, and
    the caller keeps the analytic forward_margin.
    """
    x = box_sample(lo, hi)
    d = np.abs(np.asarray(run(x), dtype=float) - np.asarray(wide(x), dtype=float))
    measured = float(np.max(d)) if np.all(np.isfinite(d)) else np.inf
    if not (0.0 < measured < np.inf or (whole and measured == 0.0)):
        return None
    xmax = np.maximum(np.abs(lo), np.abs(hi))
    return Measured(MEASURED_SAFETY * measured + float32_margin(layers, xmax), measured, len(x))
