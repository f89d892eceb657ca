"""Generated control predictors (their quantized IR given): the per-tick integer twin, the float features."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seagen.data.features import derive
from seagen.geometry import Geometry
from seagen.ir import FloatModel, QModel
from seagen.reference import float_ref, numpy_ref
from seagen.runtime import features as F
from seagen.runtime import fixed as P
from seagen.runtime import nn as K
from seagen.runtime.actq import ActQ, act_q_of
from seagen.runtime.control import FORCE_FRAC, Predictor


class StepTwin:
    """Twin of NAME_predict_q16 (NAME_step + scaling to Q16 mm) for a batch, one call per tick.

    The feature pipeline is sea_features' twin (seagen.runtime.features.Pipeline): its state starts reset,
    like NAME_reset.
    """

    def __init__(self, prefix: str, qm: QModel, act: ActQ | None = None) -> None:
        self.qm = qm
        self.act = act or act_q_of()
        self.pipeline = F.Pipeline(self.act)

    def __call__(self, enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
        """Desired compression (Q16 mm, int64) for raw counts and the desired force (Q16 N)."""
        return self.on_features(self.pipeline.step(enc, pot), force_q16)

    def shared(self, pipeline: F.Pipeline) -> Predictor:
        """Twin of NAME_predict_features_q16: a predictor reading `pipeline.last`, the step the actuator's
        shared pipeline made this tick (before the controller tick), instead of stepping its own."""

        def predict(enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
            assert pipeline.last is not None, "the shared pipeline has not stepped this tick"
            return self.on_features(pipeline.last, force_q16)

        return predict

    def on_features(self, step: F.Step, force_q16: np.ndarray) -> np.ndarray:
        """Twin of NAME_step_features + scaling to Q16 mm: the prediction from one pipeline step."""
        b, d, dd = step
        force = np.broadcast_to(np.asarray(force_q16, np.int64), b.shape[1:])
        names = F.external_inputs(self.qm)
        fr = {q.signal.name: q.frac for q in self.qm.inputs}
        ext = np.stack([K.to_s16(force, FORCE_FRAC, fr[n]) for n in names], axis=1) if names else None
        y = numpy_ref.infer(self.qm, F.inputs(self.act, self.qm.inputs, b, d, dd, ext))
        return K.to_s32(y, self.qm.out_frac, P.COMP_FRAC_BITS)


def float_features(
    names: list[str], enc: np.ndarray, pot: np.ndarray, force_n: np.ndarray, geo: Geometry
) -> np.ndarray:
    """Physical model inputs (n, n_in) from the last three samples (rows k-2, k-1, k) of enc and pot,
    computed by the one feature function (seagen.data.features.derive) with the actuator's geometry `geo`,
    one trial per actuator."""
    n = np.shape(enc)[1]
    rows = pd.DataFrame({"trial": np.tile(np.arange(n), 3), "enc": np.ravel(enc), "pot": np.ravel(pot)})
    last = derive(rows.sort_values("trial", kind="stable"), geo).groupby("trial").tail(1)
    return last.assign(force_n=np.asarray(force_n, float))[names].to_numpy(dtype=float)


def float_predictor(fm: FloatModel, geo: Geometry):
    """The float model `fm` as a CloudPredictor function: (enc rows, pot rows, force N) -> mm, its features
    computed with the geometry `geo` of the actuator it was trained on."""
    names = [s.name for s in fm.inputs]

    def fn(enc: np.ndarray, pot: np.ndarray, force_n: np.ndarray) -> np.ndarray:
        return float_ref.predict(fm, float_features(names, enc, pot, force_n, geo))

    return fn
