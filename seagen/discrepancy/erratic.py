"""Held-out trials no fit can follow: the twin jumps under a millionth's change of the fitted parameters.

A plant whose response is a smooth function of its parameters moves its twin by about a millionth of its
sensitivity when they change by a millionth. Where the response is unstable (slow sliding on a friction that
falls with speed, which the massless shaft turns into stick-slip whose timing depends on the last digits),
the twin of the same trial can move by whole noise sigmas instead. Such a trial's residual says nothing about
a missing effect, so the verdict may be read on the other held-out trials (said in words).
"""

from __future__ import annotations

import numpy as np

from seagen.discrepancy.replay import ParamSet, Runs, simulate
from seagen.discrepancy.residuals import rms, zscores

TINY = 1e-6  # relative change of every fitted parameter, up and down
ERRATIC = 0.1  # a trial whose twin moves by more than this RMS (noise sigmas) under that change is erratic
ERRATIC_SHARE = 1 / 3  # the verdict is read without erratic trials only while they are at most this share


def moved(
    base, params: ParamSet, held: Runs, sig_h: dict[str, np.ndarray], z: dict[str, np.ndarray]
) -> np.ndarray:
    """Per held-out trial, the largest RMS change (noise sigmas) of the twin of `base` with `params` (whose
    residual is `z`) when every parameter moves by +-TINY of its value (a parameter at 0 stays there)."""
    sets = [{e: {p: v * (1 + s * TINY) for p, v in ps.items()} for e, ps in params.items()} for s in (1, -1)]
    nudged = zscores(held, simulate(base, sets, held), sig_h)
    trials = np.eye(len(held.angle), dtype=bool)
    return np.array(
        [
            max(rms({c: nudged[c][k] - z[c] for c in z}, trials[i]) for k in (0, 1))
            for i in range(len(held.angle))
        ]
    )


def erratic(
    base, params: ParamSet, held: Runs, sig_h: dict[str, np.ndarray], z: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """(erratic trials as a mask over the held-out trials, how far each trial's twin moved); `z` is the
    held-out residual of `base` with `params` (a replay of one set is bit for bit that set in any batch)."""
    m = moved(base, params, held, sig_h, z)
    return m > ERRATIC, m
