"""Erratic held-out trials: a twin that jumps under a millionth's change of its parameters is found, a smooth
one is not, and the verdict is read without such trials only as the rule says."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.actuator import load_actuator
from seagen.discrepancy import workflow as W
from seagen.discrepancy.bench import make_case
from seagen.discrepancy.erratic import ERRATIC, erratic
from seagen.discrepancy.residuals import noise_sigma
from tests.conftest import EXAMPLE_ACTUATOR


def _held(case):
    _, held_i = W.split_trials(case.runs)
    sig = noise_sigma(case.runs)
    return case.runs.take(held_i), {c: s[held_i] for c, s in sig.items()}


def _erratic(case, held, sig_h):
    """erratic() at the case's truth, with the truth's held-out residual."""
    z = W._residual(W._apply(case.base, case.hidden), held, sig_h)
    return erratic(case.base, case.hidden, held, sig_h, z)


def test_stick_slip_trial_is_erratic_and_smooth_ones_are_not():
    """stiff_24v's Stribeck draw of seed 3 slides slowly in contact, where the massless shaft's stick-slip
    timing hangs on the last digits: a trial's twin moves by sigmas (18 deg on this machine; which trial may
    depend on the last bits of exp), at most a third of them. The same draw on the paper's actuator, and a
    backlash, move no trial beyond a hundredth of the threshold."""
    stiff = load_actuator(EXAMPLE_ACTUATOR)
    case = make_case(("stribeck_friction",), 3, act=stiff)
    held, sig_h = _held(case)
    bad, moved = _erratic(case, held, sig_h)
    assert 1 <= bad.sum() <= bad.size / 3 and moved.max() > 10 * ERRATIC
    for other in (make_case(("stribeck_friction",), 3), make_case(("backlash",), 3, act=stiff)):
        held, sig_h = _held(other)
        bad, moved = _erratic(other, held, sig_h)
        assert not bad.any() and moved.max() < ERRATIC / 10


@pytest.mark.slow
def test_verdict_is_read_without_the_erratic_trial_and_says_so():
    """The same case through identify: the fit leaves the erratic trial above the floor and the other five at
    it, so the verdict is explained and the note names the trial left out and why; the claims are judged as
    before the erratic trial was left out: the Stribeck fit is the closest change, not claimed, and any
    recalibration is compensation only (since a retract ends after 80 ms at any loop rate, the case
    recalibrates nothing; before, linkage_friction as compensation only)."""
    case = make_case(("stribeck_friction",), 3, act=load_actuator(EXAMPLE_ACTUATOR))
    res = W.identify(case.runs, case.base)
    assert res.verdict == "explained" and res.rms_after > W.AT_FLOOR * res.noise_floor
    note = [n for n in res.notes if "left out of the verdict" in n]
    assert len(note) == 1 and " deg left out" in note[0] and "stick-slip" in note[0]
    assert res.effects and res.effects[0].name == "stribeck_friction"
    assert not res.effects[0].claimed and res.effects[0].why.startswith("closest, not claimed")
    assert all(n.why.startswith("compensation only") for n in res.recalibrated)
    assert not np.isnan(res.rms_after)


def test_rule_reads_the_verdict_without_at_most_a_third_of_the_trials(monkeypatch):
    """_erratic_note on the truth's residual (at the floor): one or two erratic trials of six are left out and
    said; three of six are too many; none erratic gives no note; a rest above its floor gives none."""
    case = make_case(("backlash",), 3, act=load_actuator(EXAMPLE_ACTUATOR))
    held, sig_h = _held(case)
    named = [W.Named("backlash", case.hidden["backlash"], 1.0)]
    z1 = W._residual(W._apply(case.base, case.hidden), held, sig_h)
    n = len(held.angle)

    def flagged(*idx):
        mask = np.isin(np.arange(n), idx)
        return lambda *a: (mask, np.where(mask, 3.0, 0.0))

    monkeypatch.setattr(W, "erratic", flagged(2))
    note = W._erratic_note(case.base, named, held, sig_h, z1)
    assert note and f"{held.angle[2]:g} deg" in note and f"other {n - 1}" in note
    monkeypatch.setattr(W, "erratic", flagged(1, 3))  # two of six: a third, still read without them
    assert "other 4" in W._erratic_note(case.base, named, held, sig_h, z1)
    monkeypatch.setattr(W, "erratic", flagged(0, 2, 4))
    assert W._erratic_note(case.base, named, held, sig_h, z1) is None
    monkeypatch.setattr(W, "erratic", flagged())
    assert W._erratic_note(case.base, named, held, sig_h, z1) is None
    monkeypatch.setattr(W, "erratic", flagged(2))
    worse = {c: v * 3.0 for c, v in z1.items()}
    assert W._erratic_note(case.base, named, held, sig_h, worse) is None
