"""Blind set 3 (discrepancy.blindforms3): every form builds, draws per seed, and changes the signals."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from seagen.discrepancy.blindforms3 import BLIND_FORMS, CHANNELS, CLASSES, FORMS, blind_case, effect_rms
from seagen.plant import Plant, PlantConfig


def test_set_covers_the_brief():
    """At least 14 forms; the classes and designs the brief asks for, each at least as often as asked."""
    assert len(BLIND_FORMS) >= 14
    classes = Counter(f.expected_class for f in FORMS.values())
    need = {"periodic": 3, "drift": 2, "state_friction": 2, "hysteresis": 2, "nonlinear_stiffness": 1}
    need |= {"sensor_lag": 1, "quantisation": 1, "saturation": 1, "other": 2}
    assert all(classes[c] >= k for c, k in need.items()), classes
    designs = Counter(f.design for f in FORMS.values())
    assert designs["fast_48v"] >= 3 and designs["stiff_24v"] >= 2 and designs["micro_6v"] >= 2, designs


@pytest.mark.parametrize("name", BLIND_FORMS)
def test_form_builds_and_draws_per_seed(name):
    """A case is a Plant subclass on the design's own default config (truth = base), its expectations from
    the fixed vocabularies, its parameters in their ranges, the same for a seed and different across seeds;
    the plant steps and reads."""
    cls, truth, base, info = blind_case(name, 7)
    form = FORMS[name]
    assert issubclass(cls, form.cls) and issubclass(cls, Plant)
    assert isinstance(truth, PlantConfig) and truth == base == PlantConfig(actuator=truth.actuator)
    assert (
        info["expected_class"] in CLASSES and info["channels"] in CHANNELS and info["design"] == form.design
    )
    for k, (lo, hi) in form.ranges.items():
        v = abs(info["truth"][k]) if k in form.signed else info["truth"][k]
        assert lo <= v <= hi, (k, v)
    again = blind_case(name, 7)[3]["truth"]
    other = blind_case(name, 8)[3]["truth"]
    assert again == info["truth"] and other != info["truth"]
    plant = cls(truth, np.array([8.0, 20.0]), seed=1)
    for k in range(30):
        plant.step(truth.motor.supply_v * 0.5)
        if k % 10 == 0:
            s = plant.read()
    assert np.all(np.isfinite(s.load_cell_n)) and s.pot.dtype == np.int64


@pytest.mark.slow
@pytest.mark.parametrize("name", BLIND_FORMS)
def test_form_changes_the_signals(name):
    """Seed 0: the logged command of a short session replayed through truth and base plants (same noise)
    differs by more than the sensor noise (RMS, noise sigmas) on some channel."""
    rms = effect_rms(name, 0)
    assert max(rms.values()) > 1.0, rms
