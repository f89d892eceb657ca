"""The feature pipeline's Python twin (c_runtime/sea_features.c): one owner for features in and out of C.

sea_features_step keeps the previous two samples of three base signals — pot (counts, Q0), enc (counts,
Q0) and the compression (Q16 mm, sea_compression_q16) — and gives their first and second backward
differences with a warm-up (`Differences`); the angle is pot * pot_deg_q24 + pot_offset_q24 (Q24 deg). The
actuator's constants come from one `ActQ` (seagen/runtime/actq.py), the C's `const sea_act *`.
`FEATURES` names every model input the pipeline can compute; the float feature function
(seagen.data.features.derive) builds its columns from the same table and the same `Differences`.
Constants (signal indices, kinds) are read from sea_features.h, their one definition.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from seagen.c_runtime import defines
from seagen.errors import UserError
from seagen.ir import FeatureSource, QInput, QModel
from seagen.runtime import fixed as P
from seagen.runtime import nn as K
from seagen.runtime.actq import ActQ

_H = defines("sea_features.h")
N_BASE = _H["SEA_FEAT_N_BASE"]
BASE_C = {_H[f"SEA_FEAT_{k}"]: f"SEA_FEAT_{k}" for k in ("POT", "ENC", "COMP")}  # base signal -> C name
KIND_C = {_H[f"SEA_FEAT_{k}"]: f"SEA_FEAT_{k}" for k in ("BASE", "D", "DD", "ANGLE", "EXTERNAL")}
POT, ENC, COMP = BASE_C
BASE, D, DD, ANGLE, EXTERNAL = KIND_C
BASE_C_KINDS = (BASE, D, DD)  # kinds whose index names a base signal
BASE_FRAC = {POT: 0, ENC: 0, COMP: P.COMP_FRAC_BITS}


@dataclass(frozen=True)
class Feature:
    """A named feature: its source in the pipeline and the float column derive() fills."""

    name: str
    kind: int
    index: int


# Every feature the firmware computes, by name: base signals, their d_/dd_ differences, the angle, and the
# external desired force. The float names of the base signals are derive()'s columns.
BASE_NAMES = {POT: "pot", ENC: "enc", COMP: "compression_mm"}
FEATURES: dict[str, Feature] = {
    f.name: f
    for f in [
        *(Feature(n, BASE, i) for i, n in BASE_NAMES.items()),
        *(Feature(f"d_{n}", D, i) for i, n in BASE_NAMES.items()),
        *(Feature(f"dd_{n}", DD, i) for i, n in BASE_NAMES.items()),
        Feature("angle_deg", ANGLE, 0),
        Feature("force_n", EXTERNAL, 0),
    ]
}


def name_of(kind: int, index: int) -> str:
    """The name of the feature of `kind` on base signal `index` (e.g. D, ENC -> 'd_enc')."""
    return next(f.name for f in FEATURES.values() if (f.kind, f.index) == (kind, index))


def source_of(name: str, frac: int) -> FeatureSource | None:
    """Where NAME_step takes the input `name` from; None for an input the pipeline does not compute (a bare
    network on other inputs: it exports NAME_infer alone)."""
    f = FEATURES.get(name)
    if f is None:
        return None
    from_frac = {ANGLE: _H["SEA_FEAT_ANGLE_FRAC_BITS"], EXTERNAL: frac}.get(f.kind, BASE_FRAC.get(f.index, 0))
    return FeatureSource(f.kind, f.index, from_frac)


def frac_cap(name: str) -> int | None:
    """The finest input format worth choosing: the compression and its differences are computed in Q16."""
    f = FEATURES.get(name)
    return P.COMP_FRAC_BITS if f is not None and f.kind in (BASE, D, DD) and f.index == COMP else None


class Differences:
    """Twin of the difference part of sea_features_step, for any arrays of values (int64 or float).

    The first call after construction (sea_features_reset) takes x[-1] = x[-2] = x, so d = dd = 0; the
    second takes x[-2] = x[-1]. d = x - x[-1], dd = x - 2 x[-1] + x[-2], in that order of operations.
    """

    def __init__(self) -> None:
        self.p1: np.ndarray | None = None
        self.p2: np.ndarray | None = None

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(d, dd) of this sample; the state moves on by one sample."""
        if self.p1 is None or self.p2 is None:
            self.p1, self.p2 = x, x
        d, dd = x - self.p1, x - 2 * self.p1 + self.p2
        self.p2, self.p1 = self.p1, x
        return d, dd


def over_trials(x: np.ndarray, trial: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`Differences` run over recorded samples x (k, N), restarting at every trial start (as NAME_reset).

    The trials run side by side: sample j of every trial is one call, so the loop is as long as the
    longest trial.
    """
    x, trial = np.asarray(x), np.asarray(trial)
    n = x.shape[-1]
    start = np.r_[True, trial[1:] != trial[:-1]] if n else np.zeros(0, bool)
    seg = np.cumsum(start) - 1
    pos = np.arange(n) - np.flatnonzero(start)[seg] if n else np.zeros(0, int)
    grid = np.zeros((int(pos.max(initial=-1)) + 1, *x.shape[:-1], int(seg.max(initial=-1)) + 1), x.dtype)
    grid[pos, ..., seg] = np.moveaxis(x, -1, 0)
    diff, d, dd = Differences(), np.zeros_like(grid), np.zeros_like(grid)
    for j in range(len(grid)):
        d[j], dd[j] = diff(grid[j])
    return np.moveaxis(d[pos, ..., seg], 0, -1), np.moveaxis(dd[pos, ..., seg], 0, -1)


def bases_q(a: ActQ, enc: np.ndarray, pot: np.ndarray) -> np.ndarray:
    """The integer base signals (N_BASE, ...) of sea_features_step: pot, enc, compression Q16 mm."""
    enc, pot = np.asarray(enc, dtype=np.int64), np.asarray(pot, dtype=np.int64)
    b = np.zeros((N_BASE, *np.shape(enc)), dtype=np.int64)
    b[POT], b[ENC], b[COMP] = pot, enc, P.compression_q16(a, enc, pot)
    return b


def angle_q24(a: ActQ, pot: np.ndarray) -> np.ndarray:
    """Eq. 5 in Q24 deg from raw pot counts, exact in int64 (sea_features_value, SEA_FEAT_ANGLE)."""
    return np.asarray(pot, dtype=np.int64) * a.pot_deg_q24 + a.pot_offset_q24


Step = tuple[np.ndarray, np.ndarray, np.ndarray]  # one sea_features_out: (b, d, dd), each (N_BASE, batch)


class Pipeline:
    """Twin of sea_features_state with sea_features_step, for a batch of actuators (one call per tick).

    `last` is the latest step's output, the twin of a sea_features_out that an actuator's models share
    (NAME_step_features, NAME_predict_features_q16 read it instead of running a pipeline of their own).
    """

    def __init__(self, a: ActQ) -> None:
        self.act, self.diff = a, Differences()
        self.last: Step | None = None

    def step(self, enc: np.ndarray, pot: np.ndarray) -> Step:
        """(b, d, dd), each (N_BASE, batch), of one sample of raw counts."""
        b = bases_q(self.act, enc, pot)
        self.last = (b, *self.diff(b))
        return self.last


def value(a: ActQ, kind: int, index: int, b: np.ndarray, d: np.ndarray, dd: np.ndarray) -> np.ndarray:
    """sea_features_value: the base signal, difference or angle of one step (b, d, dd: (N_BASE, ...))."""
    return angle_q24(a, b[POT]) if kind == ANGLE else {BASE: b, D: d, DD: dd}[kind][index]


def inputs(
    a: ActQ, qins: Sequence[QInput], b: np.ndarray, d: np.ndarray, dd: np.ndarray, ext: np.ndarray | None
) -> np.ndarray:
    """The int16 inputs (N, n_in) NAME_step gives NAME_infer: each input's sea_features_value converted
    by sea_to_s16 to its format, or its already-quantized external argument (ext: (N, n_ext))."""
    cols = []
    for q in qins:
        src = q.source
        if src is None:
            raise UserError(f"input '{q.signal.name}' is not a feature the firmware pipeline computes")
        if src.kind == EXTERNAL:
            assert ext is not None, "this model needs external inputs (desired force)"
            cols.append(np.asarray(ext, dtype=np.int64).reshape(b.shape[1], -1)[:, src.index])
        else:
            cols.append(K.to_s16(value(a, src.kind, src.index, b, d, dd), src.from_frac, q.frac))
    return np.stack(cols, axis=1)


def not_computed(qm: QModel) -> list[str]:
    """Names of the inputs the firmware feature pipeline does not compute (then there is no NAME_step)."""
    return [q.signal.name for q in qm.inputs if q.source is None]


def has_pipeline(qm: QModel) -> bool:
    """True when the firmware feature pipeline computes every input (then NAME_step is generated too)."""
    return not not_computed(qm)


def sources(qm: QModel) -> list[FeatureSource]:
    """Every input's source; a model the pipeline cannot feed is an error naming the first such input."""
    if missing := not_computed(qm):
        raise UserError(
            f"input '{missing[0]}' is not a feature the firmware pipeline computes "
            f"(known: {', '.join(FEATURES)})"
        )
    return [q.source for q in qm.inputs if q.source is not None]


def is_predictor(qm: QModel) -> bool:
    """Whether the model maps the desired force (one external input) to a compression in at most Q16: then
    it is a sea_control predictor (NAME_predict_q16)."""
    ext = [q for q in qm.inputs if q.source is not None and q.source.kind == EXTERNAL]
    return (
        qm.output.name == "compression_mm"
        and [q.signal.name for q in ext] == ["force_n"]
        and qm.out_frac <= P.COMP_FRAC_BITS
    )


def external_inputs(qm: QModel) -> list[str]:
    """Names of the inputs NAME_step takes as arguments (already quantized), in argument order."""
    ext = sorted(
        (q.source.index, q.signal.name)
        for q in qm.inputs
        if q.source is not None and q.source.kind == EXTERNAL
    )
    return [name for _, name in ext]


def step_features(
    qm: QModel,
    a: ActQ,
    enc: np.ndarray,
    pot: np.ndarray,
    trial: np.ndarray,
    external: np.ndarray | None = None,
) -> np.ndarray:
    """The int16 model inputs NAME_step computes, for whole recorded trials (N samples) at once."""
    b = bases_q(a, enc, pot)
    d, dd = over_trials(b, trial)
    return inputs(a, qm.inputs, b, d, dd, external)
