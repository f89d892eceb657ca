"""Bit-for-bit checks: generated C (cffi) == numpy reference == torch twin == onnxruntime graph."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from seagen.reference import numpy_ref, onnx_ref, torch_ref
from seagen.toolchain.target import Target


@dataclass
class Check:
    """Outcome of comparing every implementation on the same inputs."""

    name: str
    rows: int
    mismatches: dict[str, str] = field(default_factory=dict)  # implementation -> first mismatching input
    compared: str = "C == numpy == torch == onnxruntime"
    c_out: np.ndarray | None = field(default=None, repr=False, compare=False)  # what C returned, if run

    @property
    def ok(self) -> bool:
        """No implementation differed."""
        return not self.mismatches

    def line(self) -> str:
        """One line for the console."""
        if self.ok:
            return f"{self.name}: {self.rows} rows, {self.compared} (bit for bit)"
        return f"{self.name}: MISMATCH " + "; ".join(f"{k}: {v}" for k, v in self.mismatches.items())


def first_mismatch(a: np.ndarray, b: np.ndarray, inputs: np.ndarray) -> str | None:
    """None if equal, else the first differing row with its input."""
    if np.array_equal(a, b):
        return None
    i = int(np.argmax(a != b))
    return f"row {i}, input {inputs[i].tolist()}: {int(a[i])} vs {int(b[i])}"


def random_inputs(qm, n: int, seed: int) -> np.ndarray:
    """n int16 input rows: half across the calibrated box widened by its span, half across all of int16."""
    rng = np.random.default_rng(seed)
    lo = np.array([i.lo_q for i in qm.inputs])
    hi = np.array([i.hi_q for i in qm.inputs])
    span = hi - lo
    near = rng.integers(
        np.maximum(lo - span, -(2**15)), np.minimum(hi + span, 2**15 - 1) + 1, (n // 2, len(lo))
    )
    return np.vstack([near, rng.integers(-(2**15), 2**15, (n - n // 2, len(lo)))])


def edge_inputs(n_in: int) -> np.ndarray:
    """0, +-1, INT16_MIN, INT16_MAX in every position (the others 0), and in all positions at once."""
    vals = [0, 1, -1, -(2**15), 2**15 - 1]
    rows = [np.full(n_in, v) for v in vals]
    for i in range(n_in):
        for v in vals:
            r = np.zeros(n_in, dtype=np.int64)
            r[i] = v
            rows.append(r)
    return np.array(rows)


def compare(name: str, qm, c: Target, x: np.ndarray, onnx_model=None) -> Check:
    """Run all four on int16 inputs x (N, n_in); numpy is the reference the others must equal."""
    ref = numpy_ref.infer(qm, x)
    c_out = c.infer(x)
    chk = Check(name, len(x), c_out=c_out)
    others = {
        "C": c_out,
        "torch": torch_ref.infer(qm, x),
        "onnxruntime": onnx_ref.infer(qm, x, onnx_model),
    }
    for impl, got in others.items():
        bad = first_mismatch(got, ref, np.atleast_2d(x))
        if bad:
            chk.mismatches[impl] = bad
    return chk


def step_problem(qm, target, enc, pot, trial, ext: np.ndarray, act=None) -> str | None:
    """NAME_step of a target over whole sequences (reset at each trial start) vs the numpy feature pipeline
    and reference: the first mismatch with its (trial, enc, pot), or None. `act`: the export's ActQ (the
    paper's actuator when None)."""
    from seagen.runtime.actq import act_q_of
    from seagen.runtime.features import step_features

    e = ext if ext.shape[1] else None
    ref = numpy_ref.infer(qm, step_features(qm, act or act_q_of(), enc, pot, trial, e))
    return first_mismatch(target.step(enc, pot, trial, e), ref, np.column_stack([trial, enc, pot]))


def recorded(qm, df) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """enc, pot, trial of recorded (derived) rows, and the quantized external inputs NAME_step takes
    (N, n_ext)."""
    from seagen.reference.float_ref import quantize_columns
    from seagen.runtime.features import external_inputs

    by_name = {q.signal.name: q for q in qm.inputs}
    qins = [by_name[n] for n in external_inputs(qm)]
    ext = quantize_columns(qins, df[[q.signal.name for q in qins]].to_numpy().reshape(len(df), len(qins)))
    return df.enc.to_numpy(), df.pot.to_numpy(), df.trial.to_numpy(), ext
