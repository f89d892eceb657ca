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
    """stiff_24v's Stribeck draw of seed 11 slides slowly in contact, where the massless shaft's stick-slip
    timing hangs on the last digits: a trial's twin moves by sigmas (4.8 sigma here; which trial may depend on
    the last bits of exp), at most a third of them. (Seed 3 was that draw until the structure went to the
    design's scale, 18e1b86: its twins now move 7e-6 sigma; of seeds 0-39 on stiff_24v, 17 have one such
    trial.) The paper's seed-3 Stribeck draw, and a backlash on stiff_24v, move no trial beyond a hundredth of
    the threshold."""
    stiff = load_actuator(EXAMPLE_ACTUATOR)
    case = make_case(("stribeck_friction",), 11, act=stiff)
    held, sig_h = _held(case)
    bad, moved = _erratic(case, held, sig_h)
    assert 1 <= bad.sum() <= bad.size / 3 and moved.max() > 10 * ERRATIC
    for other in (make_case(("stribeck_friction",), 3), make_case(("backlash",), 3, act=stiff)):
        held, sig_h = _held(other)
        bad, moved = _erratic(other, held, sig_h)
        assert not bad.any() and moved.max() < ERRATIC / 10


@pytest.mark.slow
def test_verdict_on_the_stick_slip_draw_claims_nothing_and_leaves_out_only_what_it_says():
    """The seed-3 draw of the test above through identify. Its held-out trials slide slowly in contact, where
    the massless shaft's stick-slip hangs on the last bits of the replay (and so of the fit, which goes
    through BLAS and LAPACK, whose kernels differ by CPU). With the structure at the paper's 30 N/mm the fit
    left the 18 deg trial at 2.7 sigma and the other five at the floor on one machine (explained, that trial
    left out and said), 1.87 sigma over all six on another (unexplained), Stribeck never claimed. With the
    structure at stiff_24v's own scale (60 N/mm, since 18e1b86) the same draw ends explained here with
    Stribeck claimed and all six trials at the floor (0.994 sigma, floor 1.018), no trial left out. What is
    promised on every CPU: nothing but the hidden Stribeck named or claimed; any recalibration compensation
    only; `explained` only at the floor, over all six with Stribeck claimed or with the erratic trial named
    in the note and the rest at the floor; `unexplained` claims nothing; the residual finite."""
    case = make_case(("stribeck_friction",), 3, act=load_actuator(EXAMPLE_ACTUATOR))
    res = W.identify(case.runs, case.base)
    assert res.verdict in ("explained", "unexplained")
    assert res.effects and res.effects[0].name == "stribeck_friction"
    assert all(not n.claimed for n in res.effects[1:])
    assert all(n.why.startswith("compensation only") for n in res.recalibrated)
    note = [n for n in res.notes if "left out of the verdict" in n]
    at_floor = res.rms_after <= W.AT_FLOOR * res.noise_floor
    if res.verdict == "explained" and not note:
        assert at_floor and res.effects[0].claimed
    elif res.verdict == "explained":
        assert len(note) == 1 and " deg left out" in note[0] and "stick-slip" in note[0] and not at_floor
    else:
        assert not note and not res.effects[0].claimed
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
