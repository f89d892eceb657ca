"""Surface fit (SF, paper §VII): a 3rd-order polynomial in two raw inputs, fitted for MSE or MAE."""

from __future__ import annotations

from typing import Any

import numpy as np

from seagen.ir import poly2

ORDER = 3


def powers_of(order: int) -> tuple[tuple[int, int], ...]:
    """Every term of total degree <= order: ascending degree, then descending power of the first input
    (order 3: 1, a, b, a², ab, b², a³, a²b, ab², b³)."""
    return tuple((d - j, j) for d in range(order + 1) for j in range(d + 1))


POWERS = powers_of(ORDER)
# Raw inputs (un-normalized) and output of each task's surface.
SF_INPUTS = {"calibration": ("angle_deg", "compression_mm"), "control": ("force_n", "angle_deg")}
SF_OUTPUT = {"calibration": "force_n", "control": "compression_mm"}
IRLS_ITERATIONS = 100
IRLS_EPS = 1e-6


def design(a: np.ndarray, b: np.ndarray, powers: tuple[tuple[int, int], ...] = POWERS) -> np.ndarray:
    """Design matrix: one column a**i * b**j per term."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.stack([a**i * b**j for i, j in powers], axis=1)


def _column_scale(x: np.ndarray) -> np.ndarray:
    """RMS of each design column (raw inputs span very different ranges), 1 where a column is zero."""
    scale = np.sqrt((x**2).mean(axis=0))
    scale[scale == 0] = 1.0
    return scale


def _lstsq(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Ordinary least squares on column-scaled terms; returns raw-input coefficients."""
    scale = _column_scale(x)
    coef, *_ = np.linalg.lstsq(x / scale, y, rcond=None)
    return coef / scale


def _weighted_normal(xs: np.ndarray, scale: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted least squares by the 10x10 normal equations of the column-scaled terms xs = x / scale."""
    xw = xs * w[:, None]
    return np.linalg.solve(xs.T @ xw, xw.T @ y) / scale


def fit_mse(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Ordinary least squares (Eq. 8)."""
    return _lstsq(x, y)


def fit_mae(x: np.ndarray, y: np.ndarray, iterations: int = IRLS_ITERATIONS) -> np.ndarray:
    """Least absolute deviations (Eq. 7) by iteratively re-weighted least squares, started from OLS."""
    coef = _lstsq(x, y)
    eps = IRLS_EPS * max(float(np.abs(y).max()), 1.0)
    scale = _column_scale(x)
    xs = x / scale
    for _ in range(iterations):
        r = np.abs(y - x @ coef)
        new = _weighted_normal(xs, scale, y, 1.0 / np.maximum(r, eps))
        if np.allclose(new, coef, rtol=1e-9, atol=1e-12):
            return new
        coef = new
    return coef


def fit_sf(a: np.ndarray, b: np.ndarray, y: np.ndarray, loss: str, order: int = ORDER) -> dict[str, Any]:
    """Fit the surface of total degree `order` (the paper's 3: 10 terms); returns the coefficient part of the
    model file (without input names). Any order exports when its Horner program's widths are proven
    (seagen.quant.sf)."""
    powers = powers_of(order)
    x = design(a, b, powers)
    y = np.asarray(y, dtype=float)
    if loss == "mse":
        coef = fit_mse(x, y)
    elif loss == "mae":
        coef = fit_mae(x, y)
    else:
        raise ValueError(f"unknown loss {loss!r}")
    return {"powers": [list(p) for p in powers], "coef": [float(c) for c in coef]}


def eval_sf(sf: dict[str, Any], a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Evaluate a stored surface {"powers", "coef"} at raw inputs (float64 reference)."""
    powers = tuple((int(i), int(j)) for i, j in sf["powers"])
    return poly2(powers, np.asarray(sf["coef"], dtype=float), a, b)
