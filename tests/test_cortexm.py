"""The generated C cross-compiled for Cortex-M4 and M0+ runs on an emulated core, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.data.schema import load_split
from seagen.defaults import DEFAULT_PREFIX, GENERATED
from seagen.errors import UserError
from seagen.export import prepare
from seagen.reference import numpy_ref
from seagen.toolchain.cortexm import CPUS, CortexM, build_image, toolchain_missing
from seagen.toolchain.equivalence import edge_inputs, first_mismatch, random_inputs, recorded, step_problem

pytest.importorskip("unicorn", reason="unicorn (the Cortex-M emulator) is not installed: pip install unicorn")

MODELS = GENERATED / "models"
PREFIX = DEFAULT_PREFIX
KEYS = [(m, cpu) for m in sorted(PREFIX) for cpu in CPUS]
IDS = [f"{m}-{cpu}" for m, cpu in KEYS]


@pytest.fixture(scope="module")
def built():
    """Every default model exported and cross-compiled for both cores, keyed by (model, cpu)."""
    if msg := toolchain_missing():
        pytest.skip(msg)
    out = {}
    for name, prefix in PREFIX.items():
        ex = prepare(str(MODELS / f"{name}.pt"), prefix=prefix)
        for cpu in CPUS:
            out[(name, cpu)] = (ex, CortexM(ex.files, prefix, ex.qmodel, cpu))
    return out


@pytest.mark.parametrize("key", KEYS, ids=IDS)
def test_infer_bit_exact_on_random_andedge_inputs(built, key):
    """NAME_infer on the emulated core equals numpy_ref.infer exactly on random and edge inputs."""
    ex, mcu = built[key]
    x = np.vstack([random_inputs(ex.qmodel, 400, 7), edge_inputs(len(ex.qmodel.inputs))])
    bad = first_mismatch(mcu.infer(x), numpy_ref.infer(ex.qmodel, x), x)
    assert bad is None, f"{key} NAME_infer on {key[1]} vs numpy: {bad}"


@pytest.mark.parametrize("key", KEYS, ids=IDS)
def test_step_bit_exact_over_recorded_trials(built, key, data_dir):
    """NAME_step on raw enc/pot (reset at trial starts) equals step_features + numpy_ref.infer exactly."""
    ex, mcu = built[key]
    qm = ex.qmodel
    bad = step_problem(qm, mcu, *recorded(qm, load_split(data_dir, "test")))
    assert bad is None, f"{key} NAME_step on {key[1]} vs numpy pipeline: {bad}"


def test_missing_toolchain_is_a_clear_error(monkeypatch, tmp_path):
    """Without arm-none-eabi-gcc on PATH, building raises a UserError naming the packages to install."""
    monkeypatch.setenv("PATH", str(tmp_path))
    assert toolchain_missing() is not None
    with pytest.raises(UserError, match="gcc-arm-none-eabi"):
        build_image({"a.c": "int a(void);\nint a(void) { return 0; }\n"}, "cortex-m4", ("a",))


def test_unknown_cpu_is_rejected():
    """Only the cores the emulator models are accepted."""
    if msg := toolchain_missing():
        pytest.skip(msg)
    with pytest.raises(UserError, match="cortex-m0plus"):
        build_image({"a.c": "int a(void);\nint a(void) { return 0; }\n"}, "cortex-m7", ("a",))


def test_m0plus_core_is_armv6m(built):
    """The emulated M0+ has no Thumb-2: the Cortex-M4 image faults on it, so M0+ results are from M0+ code."""
    from unicorn import UcError

    from seagen.toolchain.cortexm import Machine

    _, m4 = built[("mlp_calibration", "cortex-m4")]
    m0 = Machine(m4.image, "cortex-m0plus")
    with pytest.raises(UcError):
        m0.call("cal_mlp_infer_batch", np.zeros((1, m4.n_in), np.int16), 1, np.zeros(1, np.int16))
