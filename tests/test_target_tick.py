"""The controller tick through the one Target interface: host (cffi) and emulated Cortex-M4/M0+ run
sea_control with the generated predictor, equal to the Python twins (controller + StepTwin) exactly."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.codegen.controller import tick_config
from seagen.control.gentwin import StepTwin
from seagen.defaults import GENERATED
from seagen.export import prepare
from seagen.runtime.control import ControlConfig, control_run, q16, sensor_walk
from seagen.setups.shipped import MODEL_FILES, export
from seagen.toolchain.cortexm import toolchain_missing
from seagen.toolchain.targets import NAMES, build_target

PREFIXES = ("ctl_sf", "ctl_mlp")


def _sequence(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raw (enc, pot) random walks within the fault limits and a desired force stepping through the
    calibrated range; the last 50 ticks ask for 25 N (a force-range fault latches)."""
    enc, pot, force = sensor_walk(seed, n, steps=(60, 30))
    force[-50:] = q16(25.0)
    return enc, pot, force


def _twin(prefix: str, cfg: ControlConfig, enc, pot, force) -> np.ndarray:
    """control_reset on the first sample, then control_step per sample, with the StepTwin predictor."""
    twin = StepTwin(prefix, export(prefix).qmodel)
    return control_run(ControlConfig(**{**cfg.__dict__, "predictor": twin}), enc, pot, force)


@pytest.mark.parametrize("target", NAMES)
@pytest.mark.parametrize("prefix", PREFIXES)
def test_tick_equals_twin(prefix, target):
    """Target.tick (NAME_tick_batch) == the Python controller twin with the per-tick predictor twin."""
    ex = prepare(str(GENERATED / "models" / MODEL_FILES[prefix]), prefix=prefix)
    if target != "host":
        if msg := toolchain_missing():
            pytest.skip(msg)
        pytest.importorskip("unicorn")
    t = build_target(target, ex.files, prefix, ex.qmodel)
    cfg = ControlConfig(pred_avg=3)
    enc, pot, force = _sequence(600, len(prefix))
    got = t.tick(tick_config(cfg), enc, pot, force)
    want = _twin(prefix, cfg, enc, pot, force)
    bad = np.flatnonzero(got != want)
    assert bad.size == 0, f"first mismatch at tick {bad[0]}: {got[bad[0]]} vs {want[bad[0]]}"
    assert (got[-40:] == 0).all() and np.abs(got[:500]).max() > 0
