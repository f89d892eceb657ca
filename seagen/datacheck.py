"""`export --check DIR`, `verify --data DIR`: an export's C on a data set's rows and recorded trials."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import onnx

from seagen.reference import onnx_ref
from seagen.toolchain.equivalence import Check, compare, recorded, step_problem
from seagen.toolchain.model import CModel


@dataclass
class DataReport:
    """Checks on a data directory plus the float-vs-fixed error."""

    checks: list[Check]
    max_err: float
    unit: str
    bound: float
    oracles: list = field(default_factory=list)  # OracleReport per split: the built C against the original

    @property
    def ok(self) -> bool:
        """Every check passed."""
        return all(c.ok for c in self.checks) and all(o.ok for o in self.oracles)

    def report(self) -> str:
        """The checks and the float-vs-fixed error as text."""
        lines = [c.line() for c in self.checks] + [o.line() for o in self.oracles]
        lines.append(
            f"max |C - float| on the test set: {self.max_err:.5f} {self.unit} "
            f"(proven bound over the box: {self.bound:.5f} {self.unit})"
        )
        return "\n".join(lines)


def data_actuator_of(ex, data_dir: str):
    """The data folder's actuator; one other than the export's model was trained for is refused (exit 2)."""
    from seagen.data.schema import data_actuator

    mine = getattr(ex, "actuator", None)
    return data_actuator(data_dir, mine, "the model was trained for", "check on data of the model's actuator")


def check_data_dir(ex, data_dir: str, target=None, onnx_model=None) -> DataReport:
    """NAME_infer on the test and validation features, NAME_step on whole recorded trials, and |C - float|;
    on `target` (default: ex.files built for the host) against `onnx_model` (default: the export's)."""
    from seagen.data.features import derive
    from seagen.data.schema import load_split
    from seagen.errors import UserError
    from seagen.geometry import geometry
    from seagen.reference.float_ref import predict, quantize_features
    from seagen.runtime.features import has_pipeline

    qm = ex.qmodel
    names = [i.signal.name for i in qm.inputs]
    step = has_pipeline(qm)
    c = target if target is not None else CModel(ex.files, ex.prefix, qm)
    if onnx_model is None:
        onnx_model = (
            onnx.load_model_from_string(ex.onnx_bytes)
            if ex.onnx_bytes is not None
            else onnx_ref.build_onnx(qm)
        )
    checks, max_err, oracles = [], 0.0, []
    geo = geometry(data_actuator_of(ex, data_dir))  # the features of the actuator the data came from
    for split in ("test", "validation"):
        df = derive(load_split(data_dir, split), geo)
        missing = [n for n in names if n not in df.columns]
        if missing:
            raise UserError(f"{data_dir}/{split}.csv: no column {', '.join(missing)} for the model's inputs")
        xq = quantize_features(qm, df[names].to_numpy())
        infer_check = compare(f"{ex.prefix}_infer on {split} rows", qm, c, xq, onnx_model)
        checks.append(infer_check)
        oracles.append(_oracle_rows(ex, f"C vs original on {split} rows", df[names].to_numpy(), infer_check))
        if split == "test":
            assert infer_check.c_out is not None
            fixed = infer_check.c_out * 2.0**-qm.out_frac
            max_err = float(np.max(np.abs(fixed - predict(ex.float_model, df[names].to_numpy()))))
        if not step:
            continue
        bad = step_problem(qm, c, *recorded(qm, df), act=ex.act)
        checks.append(
            Check(
                f"{ex.prefix}_step on {split} trials",
                len(df),
                {"C": bad} if bad else {},
                "C step == numpy pipeline + reference",
            )
        )
    return DataReport(checks, max_err, qm.output.unit, qm.error_bound, oracles)


def _oracle_rows(ex, what: str, x: np.ndarray, infer_check: Check):
    """The built C's outputs on data rows inside the calibrated box against the user's original model."""
    from seagen.reference.oracle import compare_original, in_box

    assert infer_check.c_out is not None
    keep = in_box(ex.qmodel, x)
    what = f"{what} ({int(keep.sum())} of {len(x)} inside the box)"
    return compare_original(
        what, ex.qmodel, ex.loaded.original, x[keep], ex.loaded.margin, infer_check.c_out[keep]
    )
