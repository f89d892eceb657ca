"""Integer activations shared by every reference: exact ReLU/LeakyReLU/Hardtanh, tables for tanh/sigmoid."""

from __future__ import annotations

import numpy as np

from seagen import fmath
from seagen.ir import QTable

TABLE_OUT_FRAC = 14  # table outputs are Q14 (1.0 = 16384)
TABLE_STEP_FRAC = 8  # table sampled every 2^-8 of the input
TABLE_RANGE = {"tanh": 4.0, "sigmoid": 8.0}  # beyond +-R the function is taken as saturated


def _f(name: str, x: np.ndarray) -> np.ndarray:
    return fmath.tanh(x) if name == "tanh" else 1.0 / (1.0 + fmath.exp(-x))


def make_table(name: str, in_frac: int, label: str) -> QTable:
    """Nearest-sample table of tanh or sigmoid for inputs in Q(in_frac)."""
    in_shift = max(in_frac - TABLE_STEP_FRAC, 0)
    step = 2.0 ** (in_shift - in_frac)
    offset = int(round(TABLE_RANGE[name] / step))
    x = (np.arange(2 * offset + 1) - offset) * step
    values = np.rint(_f(name, x) * 2**TABLE_OUT_FRAC).astype(np.int64)
    return QTable(label, values, in_frac, TABLE_OUT_FRAC, in_shift, offset)


def table_error(t: QTable, name: str) -> float:
    """Worst |table(x) - f(x)| (output units) for any x: half a step x Lipschitz + rounding, or tail."""
    step = 2.0 ** (t.in_shift - t.in_frac)
    lip = 1.0 if name == "tanh" else 0.25
    r = TABLE_RANGE[name]
    tail = 1.0 - fmath.tanh(r) if name == "tanh" else 1.0 / (1.0 + fmath.exp(r))
    return max(lip * step / 2, tail) + 2.0 ** -(TABLE_OUT_FRAC + 1)
