"""The command timing, a nuisance parameter of the replay: which part of its interval a command covers."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from seagen.discrepancy.replay import Runs, simulate

COARSE = np.linspace(0.0, 1.0, 11)  # lag grid, then a fine one around the best
FINE_HALF, FINE_N = 0.1, 11
DISAGREE_CHI2 = (
    25.0  # a declared convention this much worse (encoder chi-square) than the data's fit is wrong
)
NAMES = {0.0: "from_row", 1.0: "up_to_row"}


@dataclass
class Timing:
    """The command lag the replay uses, what the data says, and a warning when they disagree."""

    lag: float  # used: a logged command takes effect at t_j - lag * (t_j - t_{j-1})
    fitted: float  # best fit on the fitting trials (encoder), in [0, 1]
    pinned: float | None  # declared in the map ([log] command), else None
    period_s: float  # median logged sample period
    chi2: dict[float, float] = field(default_factory=dict)  # encoder chi-square per lag tried
    warning: str = ""

    @property
    def offset_ms(self) -> float:
        """The lag used, in ms of the median period (how far before its row a command takes effect)."""
        return self.lag * self.period_s * 1000.0

    def words(self) -> str:
        """One line for the report."""
        conv = NAMES.get(round(self.lag, 2), "between the two conventions")
        how = "declared in the map" if self.pinned is not None else "fitted on the data (nuisance parameter)"
        return (
            f"command timing: lag {self.lag:.2f} of a sample period ({self.offset_ms:.2f} ms before its row; "
            f"{conv}), {how}; data's best fit {self.fitted:.2f}"
        )


def _profile(base, runs: Runs, sig_enc: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Encoder chi-square of the base plant for each lag (all trials replayed in one batch)."""
    n = len(runs.angle)
    big = runs.take(np.tile(np.arange(n), len(lags)))
    big.lag = np.repeat(lags, n)
    sim = simulate(base, [{}], big)["enc"][0]
    z = (big.meas["enc"] - sim) / np.tile(sig_enc, len(lags))[:, None]
    return np.nansum(z**2, axis=1).reshape(len(lags), n).sum(axis=1)


def fit_timing(base, runs: Runs, sig_enc: np.ndarray, pinned: float | None = None) -> Timing:
    """The lag in [0, 1] that best replays the encoder (coarse grid, then a fine one); the pinned lag when
    the map declares one, with a warning when the data clearly disagree."""
    chi = dict(zip(COARSE.tolist(), _profile(base, runs, sig_enc, COARSE).tolist(), strict=True))
    best = min(chi, key=chi.__getitem__)
    fine = np.clip(np.linspace(best - FINE_HALF, best + FINE_HALF, FINE_N), 0.0, 1.0)
    fine = np.unique(np.round(fine, 4))
    chi.update(zip(fine.tolist(), _profile(base, runs, sig_enc, fine).tolist(), strict=True))
    best = float(min(chi, key=chi.__getitem__))
    d = np.diff(runs.t, axis=1)[runs.mask[:, 1:]]
    period = float(np.median(d)) if d.size else 0.01
    out = Timing(best if pinned is None else float(pinned), best, pinned, period, chi)
    if pinned is not None:
        if float(pinned) not in chi:
            chi[float(pinned)] = float(_profile(base, runs, sig_enc, np.array([float(pinned)]))[0])
        worse = chi[float(pinned)] - chi[best]
        if worse > DISAGREE_CHI2 and abs(best - float(pinned)) >= 0.25:
            name = NAMES.get(float(pinned), f"lag {pinned}")
            out.warning = (
                f"the map declares the command '{name}' (lag {float(pinned):g}) but the data fit lag "
                f"{best:.2f} ({NAMES.get(round(best), '')}; encoder chi-square {chi[best]:.4g} vs "
                f"{chi[float(pinned)]:.4g}); the replay uses the declared one: check [log] command"
            )
    return out
