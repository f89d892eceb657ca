"""Blind forms (issue 39 item 3): each form builds, its expectations are complete, it moves the logs."""

from __future__ import annotations

from seagen.discrepancy.blindforms import BLIND_FORMS, CLASSES, FORMS, blind_case, signal_change
from seagen.plant.config import CATALOGUE


def test_forms_build_with_committed_expectations() -> None:
    """Every form's case draws its parameters in range and states a class, channels and true values."""
    assert len(BLIND_FORMS) >= 12 and sum(FORMS[n].expected_class == "other" for n in BLIND_FORMS) >= 2
    assert {FORMS[n].expected_class for n in BLIND_FORMS} == set(CLASSES)
    for name in BLIND_FORMS:
        cls, truth, base, expect = blind_case(name, 3)
        assert truth == base and not any(truth.on(e) != base.on(e) for e in CATALOGUE)
        assert expect["expected_class"] in CLASSES and expect["channels"] in ("force", "position", "both")
        bounds = FORMS[name].bounds()
        assert all(lo <= expect["truth"][k] <= hi for k, (lo, hi) in bounds.items()), name
        assert all(getattr(cls, k) == expect["truth"][k] for k in bounds)


def test_forms_change_the_signals_on_their_channels() -> None:
    """On a short session (0.6 s trials, same commands and noise) each form moves a logged channel by more
    than its noise; a sensor form on one channel leaves the other channels exactly as they were."""
    change = signal_change(seed=1, max_s=0.6)
    for name, ch in change.items():
        assert max(ch.values()) > 1.0, (name, ch)
        acting = FORMS[name].channels
        position, force = ch["enc"] + ch["pot"], ch["load_cell_n"]
        if acting == "force":
            assert position == 0.0 and force > 1.0, (name, ch)
        elif acting == "position":
            assert force == 0.0 and ch["enc"] == 0.0 and ch["pot"] > 1.0, (name, ch)
        else:
            assert position > 0.0 and force > 0.0, (name, ch)
