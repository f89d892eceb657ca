"""The integer feature pipeline: which raw-count computation feeds each model input, and its formats.

Base signals, all exact integers: pot (counts, Q0), enc (counts, Q0), compression (Q16 mm, from
sea_compression_q16), angle (Q24 deg, pot * POT_DEG_Q24 + POT_OFFSET_Q24). First and second backward
differences (seagen.data.features.differences, warm-up included) are taken on pot, enc and compression.
External inputs (the desired force of a control predictor) arrive already quantized.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from seagen.data.features import differences
from seagen.errors import UserError
from seagen.ir import QModel
from seagen.quant import kernels as K
from seagen.quant import primitives as P

BASES = ("pot", "enc", "compression_mm")  # state-carrying signals, in state-struct order
BASE_FRAC = {"pot": 0, "enc": 0, "compression_mm": P.COMP_FRAC_BITS}
EXTERNAL = ("force_n",)


@dataclass(frozen=True)
class FeatureSource:
    """Model input i comes from `kind` ('base', 'd', 'dd', 'angle', 'external') of base `index`."""

    kind: str
    index: int
    from_frac: int
    to_frac: int


def feature_plan(qm: QModel) -> list[FeatureSource]:
    """One source per model input; an input the pipeline cannot compute is an error."""
    plan = []
    for qi in qm.inputs:
        name = qi.signal.name
        base = name.removeprefix("dd_").removeprefix("d_")
        kind = "dd" if name.startswith("dd_") else "d" if name.startswith("d_") else "base"
        if name == "angle_deg":
            plan.append(FeatureSource("angle", -1, 24, qi.frac))
        elif name in EXTERNAL:
            plan.append(FeatureSource("external", EXTERNAL.index(name), qi.frac, qi.frac))
        elif base in BASES:
            plan.append(FeatureSource(kind, BASES.index(base), BASE_FRAC[base], qi.frac))
        else:
            raise UserError(
                f"input '{name}' is not a feature the firmware pipeline computes "
                f"(known: {', '.join(BASES)}, their d_/dd_ differences, angle_deg, force_n)"
            )
    return plan


def external_inputs(qm: QModel) -> list[str]:
    """Names of the inputs NAME_step takes as arguments (already quantized)."""
    return [qi.signal.name for qi in qm.inputs if qi.signal.name in EXTERNAL]


def step_features(
    qm: QModel,
    table: np.ndarray,
    enc: np.ndarray,
    pot: np.ndarray,
    trial: np.ndarray,
    external: np.ndarray | None = None,
) -> np.ndarray:
    """The int16 model inputs NAME_step computes, for whole recorded trials (N samples) at once."""
    enc = np.asarray(enc, dtype=np.int64)
    pot = np.asarray(pot, dtype=np.int64)
    bases = np.stack([pot, enc, P.compression_q16(table, enc, pot)])
    d, dd = zip(*(differences(b, np.asarray(trial)) for b in bases), strict=True)
    return model_inputs(qm, bases, np.stack(d), np.stack(dd), external)


def model_inputs(
    qm: QModel, bases: np.ndarray, d: np.ndarray, dd: np.ndarray, external: np.ndarray | None
) -> np.ndarray:
    """int16 model inputs (N, n_in) from the base signals (pot, enc, compression Q16; shape (3, N)), their
    differences and the already-quantized external inputs (N, n_ext): what NAME_step does after the state."""
    cols = []
    for src in feature_plan(qm):
        if src.kind == "angle":
            v = bases[0] * P.POT_DEG_Q24 + P.POT_OFFSET_Q24
        elif src.kind == "external":
            assert external is not None, "this model needs external inputs (desired force)"
            v = np.asarray(external, dtype=np.int64).reshape(bases.shape[1], -1)[:, src.index]
        else:
            v = {"base": bases, "d": d, "dd": dd}[src.kind][src.index]
        cols.append(K.to_s16(v, src.from_frac, src.to_frac))
    return np.stack(cols, axis=1)
