"""The oracle seagen did not write: the integer reference against the user's original model, run by its own
runtime, within the proven bound (plus a stated float32 margin)."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from seagen.ir import QModel
from seagen.quant.qformat import widened_box
from seagen.reference import numpy_ref
from seagen.reference.float_ref import quantize_features

N_RANDOM = 2000
MAX_CORNERS = 512


@dataclass
class OracleReport:
    """Outcome of one comparison: worst |integer - original| against bound + margin, and the first failure."""

    what: str
    rows: int
    max_err: float
    bound: float
    margin: float
    unit: str
    first_fail: str | None = None

    @property
    def ok(self) -> bool:
        """Every row within bound + margin."""
        return self.first_fail is None

    def line(self) -> str:
        """One line for the console."""
        return f"{self.what}: {self.detail()}"

    def detail(self) -> str:
        """The outcome without the label (for a report that prints the label itself)."""
        lim = f"bound {self.bound:.3g} + margin {self.margin:.3g} {self.unit}"
        if self.ok:
            worst = f"max |integer - original| {self.max_err:.3g} {self.unit}"
            return f"{self.rows} inputs, {worst} <= {lim}"
        return f"DISAGREES at {self.first_fail} (> {lim})"


def box_points(qm: QModel, n: int = N_RANDOM, seed: int = 0) -> np.ndarray:
    """Physical inputs over the widened calibrated box: random points, the centre and corners (all corners
    up to MAX_CORNERS, else random ones)."""
    lo, hi = widened_box(i.signal for i in qm.inputs)
    rng = np.random.default_rng(seed)
    k = len(lo)
    if 2**k <= MAX_CORNERS:
        corners = np.array(list(itertools.product((0, 1), repeat=k)), dtype=float)
    else:
        corners = rng.integers(0, 2, (MAX_CORNERS, k)).astype(float)
    unit = np.vstack([rng.random((n, k)), np.full((1, k), 0.5), corners])
    return lo + unit * (hi - lo)


def compare_original(
    what: str,
    qm: QModel,
    original: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    margin: float,
    got_q: np.ndarray | None = None,
) -> OracleReport:
    """|integer(x) - original(x)| <= error_bound + margin on physical inputs x; got_q: integer outputs already
    computed (e.g. by the C), else the numpy reference is run."""
    if got_q is None:
        got_q = numpy_ref.infer(qm, quantize_features(qm, x))
    got = np.asarray(got_q, dtype=float) * 2.0**-qm.out_frac
    want = np.asarray(original(x), dtype=float).reshape(-1)
    err = np.abs(got - want)
    err = np.where(np.isfinite(err), err, np.inf)
    rep = OracleReport(what, len(x), float(np.max(err)), qm.error_bound, margin, qm.output.unit)
    bad = np.flatnonzero(~(err <= qm.error_bound + margin))
    if len(bad):
        i = int(bad[0])
        rep.first_fail = (
            f"input {np.round(x[i], 6).tolist()}: integer {got[i]:.6g}, original {want[i]:.6g} "
            f"(|diff| {err[i]:.3g} {qm.output.unit})"
        )
    return rep


def in_box(qm: QModel, x: np.ndarray) -> np.ndarray:
    """Rows of physical inputs x inside the widened box (where the bound is proven)."""
    lo, hi = widened_box(i.signal for i in qm.inputs)
    return np.all((x >= lo) & (x <= hi), axis=1)
