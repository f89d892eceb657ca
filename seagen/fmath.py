"""Float functions whose bits do not depend on the CPU: the C library's, element by element.

numpy picks its vector code for `exp`, `cos`, `arccos`, `tanh`, `log`, `cbrt` and non-integer powers by the
CPU it runs on (AVX-512 machines take SVML-derived loops, others the C library or AVX2 loops), and the
results differ in the last bit on a few percent of arguments. In a simulation that decides by comparison
(stick or slide, a trial's end), one such bit moves a trial by a sample: the 61-trial rig session had 30,989
rows on an AVX-512 machine and 30,957 on an AVX2 one. Every simulated number goes through these instead:
numba ufuncs that call the C library (glibc takes one FMA variant on every x86-64 CPU with AVX2, and arm64
builds the same source with FMA), compiled on first use and cached. `+ - * / sqrt` are exact in IEEE and
need nothing; neither do numpy's sums (one pairwise loop for every CPU).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache

import numpy as np


def _exp(x: float) -> float:
    return math.exp(x)


def _log(x: float) -> float:
    return math.log(x)


def _cos(x: float) -> float:
    return math.cos(x)


def _arccos(x: float) -> float:
    return math.acos(x)


def _tanh(x: float) -> float:
    return math.tanh(x)


def _cbrt(x: float) -> float:
    return np.cbrt(x)  # numba lowers it to the C library's cbrt


_BODIES = {"exp": _exp, "log": _log, "cos": _cos, "arccos": _arccos, "tanh": _tanh, "cbrt": _cbrt}


@cache
def _ufunc(name: str) -> Callable:
    """The numba ufunc for `name` (float64 -> float64), compiled once (and cached on disk)."""
    import numba

    made = numba.vectorize(["float64(float64)"], cache=True)(_BODIES[name])
    return getattr(made, "ufunc", made)  # the plain numpy ufunc under numba's wrapper: less per call


def _apply(name: str, x):
    """`name` of x (a scalar or an array) through the C library; a Python float for a Python number."""
    out = _ufunc(name)(np.asarray(x, dtype=float))
    return float(out) if not isinstance(x, np.ndarray) and np.ndim(out) == 0 else out


def exp(x):
    """e**x, the C library's bits."""
    return _apply("exp", x)


def log(x):
    """Natural logarithm, the C library's bits."""
    return _apply("log", x)


def cos(x):
    """Cosine of x radians, the C library's bits."""
    return _apply("cos", x)


def arccos(x):
    """Arc cosine in radians (x in [-1, 1]), the C library's bits."""
    return _apply("arccos", x)


def tanh(x):
    """Hyperbolic tangent, the C library's bits."""
    return _apply("tanh", x)


def cbrt(x):
    """Cube root, the C library's bits."""
    return _apply("cbrt", x)
