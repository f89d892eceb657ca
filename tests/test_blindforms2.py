"""Blind set 2 of hidden-effect forms: coverage, builds, reproducible draws, visible effects (slow)."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from seagen.discrepancy.blindforms2 import BLIND_FORMS, CLASSES, FORMS, blind_case, visibility
from seagen.plant import Plant


def test_the_set_covers_the_brief() -> None:
    """At least 12 forms; the classes the issue names, twice each where asked; three on other designs."""
    assert len(BLIND_FORMS) >= 12
    classes = Counter(FORMS[n].expected_class for n in BLIND_FORMS)
    assert set(classes) <= CLASSES
    for c in ("periodic", "drift", "state_friction", "hysteresis", "other"):
        assert classes[c] >= 2, c
    assert sum(FORMS[n].design != "paper" for n in BLIND_FORMS) >= 3
    assert {FORMS[n].channels for n in BLIND_FORMS} <= {"force", "position", "both"}


@pytest.mark.parametrize("name", BLIND_FORMS)
def test_each_form_builds_and_draws_per_seed(name: str) -> None:
    """The case is reproducible per seed, differs across seeds, draws inside its ranges, and its plant
    steps and reads; the base is the design's own config, the truth config the same values."""
    cls, truth, base, info = blind_case(name, 11)
    _, truth2, _, info2 = blind_case(name, 11)
    assert info == info2 and truth == truth2 and truth == base and truth is not base
    assert info["truth"] != blind_case(name, 12)[3]["truth"]
    assert info["expected_class"] in CLASSES and info["design"] == FORMS[name].design
    for key, (lo, hi) in FORMS[name].ranges.items():
        if key in info["truth"]:
            assert lo <= info["truth"][key] <= hi, key
    assert issubclass(cls, Plant)
    plant = cls(truth, np.array([8.0, 20.0]), seed=0)
    for _ in range(20):
        plant.step(3.0)
    s = plant.read()
    assert np.all(np.isfinite(s.load_cell_n)) and s.pot.dtype == np.int64


@pytest.mark.slow
@pytest.mark.parametrize("name", BLIND_FORMS)
def test_each_form_changes_the_logged_signals(name: str) -> None:
    """On the quick protocol (seed 0), the form changes the load cell or the pot by more than 1.5 noise
    sigmas RMS on the channel it acts on (the position channel: the pot, or else the encoder)."""
    v = visibility(name, 0)
    ch = FORMS[name].channels
    force_ok = v["load_cell_sigmas"] > 1.5
    pos_ok = v["pot_sigmas"] > 1.5 or v["enc_counts"] > 5
    assert {"force": force_ok, "position": pos_ok, "both": force_ok or pos_ok}[ch], v
