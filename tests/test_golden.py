"""Golden tier: tiny models rendered to C text equal the expected files in tests/golden/, byte for byte.

Any change in the emitted C (templates, render.py, quantization) shows here and in review as a diff of
tests/golden/*. When the change is intended, refresh the files and commit them with the change:

    SEAGEN_UPDATE_GOLDEN=1 .venv/bin/python -m pytest -n 0 tests/test_golden.py
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from seagen.codegen.render import render
from seagen.ir import FloatLayer, FloatMLP, FloatSF, Signal
from seagen.quant.mlp import quantize_mlp
from seagen.quant.sf import quantize_sf
from seagen.reference import numpy_ref
from seagen.toolchain.equivalence import edge_inputs, random_inputs
from seagen.toolchain.model import CModel

GOLDEN = Path(__file__).parent / "golden"
UPDATE = os.environ.get("SEAGEN_UPDATE_GOLDEN") == "1"


def tiny_mlp() -> FloatMLP:
    """4 -> 3 (leaky ReLU) -> 2 (hardtanh) -> 1: every feature kind but external, fixed numbers."""
    inputs = (
        Signal("pot", "count", 300.0, 2500.0),
        Signal("d_enc", "count", -40.0, 40.0),
        Signal("dd_compression_mm", "mm", -0.02, 0.02),
        Signal("angle_deg", "deg", 0.0, 30.0),
    )
    w0 = np.array([[1e-3, 0.02, 10.0, 0.05], [-2e-3, -0.01, 5.0, 0.1], [5e-4, 0.03, -20.0, -0.02]])
    layers = (
        FloatLayer(w0, np.array([0.1, -0.2, 0.3]), "leaky_relu", alpha=0.05),
        FloatLayer(np.array([[0.5, -0.25, 1.0], [0.75, 0.5, -0.5]]), np.array([0.0, 0.1]), "hardtanh"),
        FloatLayer(np.array([[4.0, -3.0]]), np.array([2.0])),
    )
    return FloatMLP(inputs, Signal("force_n", "N", 0.0, 20.0), layers)


def tiny_sf() -> FloatSF:
    """A 2nd-order control surface (force, angle) -> compression: external input and predictor glue."""
    inputs = (Signal("force_n", "N", 0.0, 20.0), Signal("angle_deg", "deg", 5.0, 28.0))
    powers = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    coef = (0.6, 0.24, -0.01, 1e-3, 2e-4, 5e-5)
    return FloatSF(inputs, Signal("compression_mm", "mm", 0.0, 5.5), powers, coef, task="control")


CASES = {"tiny_mlp": lambda: quantize_mlp(tiny_mlp()), "tiny_sf": lambda: quantize_sf(tiny_sf())}


@pytest.mark.parametrize("name", sorted(CASES))
def test_rendered_c_equals_golden(name):
    """NAME.h and NAME.c of a tiny model equal tests/golden/NAME.{h,c} byte for byte."""
    files = render(CASES[name](), name)
    for fname, text in files.items():
        path = GOLDEN / fname
        if UPDATE:
            path.write_text(text)
        assert path.is_file(), (
            f"{path} missing: refresh with SEAGEN_UPDATE_GOLDEN=1 (see this file's docstring)"
        )
        assert text == path.read_text(), f"{fname} differs from {path}: review the diff, then refresh"


@pytest.mark.parametrize("name", sorted(CASES))
def test_golden_c_builds_and_equals_reference(name):
    """The golden C compiles under the strict flags and its NAME_infer equals numpy_ref exactly."""
    from seagen.codegen.render import RUNTIME
    from seagen.codegen.runtime import runtime_sources

    qm = CASES[name]()
    files = {f.name: f.read_text() for f in [*GOLDEN.glob(f"{name}.*"), *GOLDEN.glob("sea_act_*")]}
    c = CModel({**files, **runtime_sources(*RUNTIME)}, name, qm)
    x = np.vstack([random_inputs(qm, 2000, 4), edge_inputs(len(qm.inputs))])
    assert np.array_equal(c.infer(x), numpy_ref.infer(qm, x))
