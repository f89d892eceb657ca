"""Exact integer interval of a dense layer's accumulator over an input box (the one owner of this proof)."""

from __future__ import annotations

import numpy as np


def acc_interval(
    w: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per neuron: [min, max] of b + W x over lo <= x <= hi, and the worst partial-sum magnitude
    |b| + sum |w| max(|lo|, |hi|) (Python-int object arrays: exact at any width)."""
    wo = w.astype(object)
    lo_o, hi_o = np.asarray(lo).astype(object), np.asarray(hi).astype(object)
    a, c = wo * lo_o[None, :], wo * hi_o[None, :]
    bo = np.asarray(b).astype(object)
    mn = np.minimum(a, c).sum(axis=1) + bo
    mx = np.maximum(a, c).sum(axis=1) + bo
    worst = (abs(wo) * np.maximum(abs(lo_o), abs(hi_o))[None, :]).sum(axis=1) + abs(bo)
    return mn, mx, worst
