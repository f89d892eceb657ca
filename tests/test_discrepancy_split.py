"""The fitting and held-out trials of the discrepancy workflow cover the same forces (issue 35 item 4)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seagen.discrepancy.replay import runs_from_frames
from seagen.discrepancy.workflow import BALANCE, split_balance, split_trials, trial_peaks


def _trial(angle: float, peak: float, n: int = 50) -> pd.DataFrame:
    """A synthetic logged trial at `angle` whose load-cell force rises to `peak` N."""
    t = np.arange(n) * 0.01
    f = peak * np.sin(np.linspace(0.0, np.pi, n))
    return pd.DataFrame(
        {"t_s": t, "motor_v": 1.0, "enc": 10 * f, "pot": 2000 + f, "load_cell_n": f, "force_n": 1.4 * f}
    ).assign(angle_set_deg=angle)


def _runs(peaks_per_angle: list[list[float]]):
    """Runs of the trials (log order: angle after angle, the given peaks in turn)."""
    frames = []
    for a, peaks in zip((6.0, 12.0, 18.0, 24.0), peaks_per_angle, strict=False):
        frames += [_trial(a, p) for p in peaks]
    df = pd.concat([f.assign(trial=i) for i, f in enumerate(frames)], ignore_index=True)
    return runs_from_frames([("log", df)])


def test_a_log_whose_strong_trials_come_first_is_split_by_force():
    """Every angle logs a strong push, then a weak one: in log order all strong trials would fit and only
    weak ones be held out (the slow design's 2 s / 8 s trials); the split takes them by force instead."""
    runs = _runs([[12.0, 0.4], [14.0, 0.5], [13.0, 0.3], [15.0, 0.4]])
    fit, held = split_trials(runs)
    peaks = trial_peaks(runs)
    assert np.allclose(np.sort(peaks), np.sort([12, 0.4, 14, 0.5, 13, 0.3, 15, 0.4]), rtol=1e-3)
    assert split_balance(runs, fit, held) >= BALANCE
    assert peaks[fit].max() > 10 and peaks[held].max() > 10
    assert not set(fit) & set(held)


def test_a_balanced_log_keeps_its_log_order_split():
    """Where log order already gives both sides the same forces, the split is the alternation it was."""
    runs = _runs([[12.0, 11.0, 5.0, 6.0], [14.0, 13.0], [9.0, 10.0], [15.0, 14.0]])
    fit, held = split_trials(runs)
    assert sorted(fit.tolist() + held.tolist()) == list(range(10))
    assert fit.tolist() == [0, 2, 4, 6, 8]
    assert held.tolist() == [1, 3, 5, 7, 9]


def test_one_trial_per_angle_alternates_over_the_angles_by_force():
    """One trial per angle, strong and weak angles in turn: the sides alternate over the angles by force."""
    runs = _runs([[12.0], [11.0], [0.5], [0.4]])
    fit, held = split_trials(runs)
    assert split_balance(runs, fit, held) >= BALANCE
