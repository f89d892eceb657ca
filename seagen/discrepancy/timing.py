"""The command timing, a nuisance parameter of the replay: which part of its interval a command covers."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from seagen.actuator import Actuator
from seagen.discrepancy.replay import SNAP_S, Runs, simulate

STEP_S = 0.015  # the lag is read from the encoder residual's step from just before a switch to this after
# (at least one motor time constant: step_time)
COARSE = np.linspace(0.0, 1.0, 11)  # lag grid, then a fine one around the best
FINE_HALF, FINE_N = 0.1, 11
POLISH_S, POLISH_N = 0.1e-3, 11  # the last step: +-0.1 ms around the best, whole-trial chi-square ...
POLISH_MAX_PERIOD_S = 2e-3  # ... for logs at >= 500 Hz (slower ones: the switch steps pin the lag alone)
DISAGREE_CHI2 = 25.0  # a declared convention this much worse (switch-step sum) than the fit is wrong
NAMES = {0.0: "from_row", 1.0: "up_to_row"}


@dataclass
class Timing:
    """The command lag the replay uses, what the data says, and a warning when they disagree."""

    lag: float  # used: a logged command takes effect at t_j - lag * (t_j - t_{j-1})
    fitted: float  # best fit on the fitting trials (encoder), in [0, 1]
    pinned: float | None  # declared (timing.json: the map's [log] command, or seagen's own logs), else None
    period_s: float  # median logged sample period
    chi2: dict[float, float] = field(default_factory=dict)  # switch-step sum of squares per lag tried
    warning: str = ""
    problem: str = ""  # the residual is the log's timing (switches off by up to a period), not physics

    @property
    def offset_ms(self) -> float:
        """The lag used, in ms of the median period (how far before its row a command takes effect)."""
        return self.lag * self.period_s * 1000.0

    def words(self) -> str:
        """One line for the report."""
        conv = NAMES.get(round(self.lag, 2), "between the two conventions")
        how = "declared by the log" if self.pinned is not None else "fitted on the data (nuisance parameter)"
        return (
            f"command timing: lag {self.lag:.2f} of a sample period ({self.offset_ms:.2f} ms before its row; "
            f"{conv}), {how}; data's best fit {self.fitted:.2f}"
        )


def step_time(act: Actuator) -> float:
    """The switch-step window: STEP_S, or the motor's time constant when that is longer (both shipped
    designs' motors are within STEP_S)."""
    return max(STEP_S, act.motor.time_constant_s)


def _switch_windows(
    runs: Runs, step_s: float = STEP_S
) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    """Per command switch (the first command from rest too): (trial, rows of the 2 step_s before it, their
    weights of a least-squares line extrapolated to the mean time of the rows step_s..2 step_s after it,
    those after rows)."""
    from seagen.discrepancy.replay import SWITCH_V

    out = []
    for i in range(len(runs.angle)):
        m = int(runs.mask[i].sum())
        v, t = runs.volts[i, :m], runs.t[i, :m]
        for j in np.flatnonzero(np.abs(np.diff(np.r_[0.0, v])) > SWITCH_V):
            b = int(j) - 1 if j > 0 else 0  # the last row before the switch (it may act from that instant)
            before = np.arange(np.searchsorted(t, t[b] - 2 * step_s), b + 1)
            after = np.arange(
                np.searchsorted(t, t[b] + step_s), np.searchsorted(t, t[b] + 2 * step_s, side="right")
            )
            if not len(after):
                continue
            x = t[before] - t[before].mean()
            at = float(t[after].mean() - t[before].mean())
            sxx = float(x @ x)
            w = np.full(len(before), 1.0 / len(before)) + (x * at / sxx if sxx > 0 else 0.0)
            out.append((i, before, w, after))
    return out


def _profile(base, runs: Runs, sig_enc: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """For each lag, the sum of squares of the base plant's encoder residual steps across the command
    switches (noise units): the mean residual step..2 step after a switch (step_time) less the line through
    the 2 step before it, extrapolated. A mis-timed switch puts a step there; slow physics (compliance,
    friction levels) barely bends the residual in that window, so a missing effect hardly pulls the lag;
    averaging over the windows keeps the encoder's rounding from deciding it at high rates. All lags
    replayed in one batch."""
    n = len(runs.angle)
    big = runs.take(np.tile(np.arange(n), len(lags)))
    big.lag = np.repeat(lags, n)
    sim = simulate(base, [{}], big)["enc"][0]
    z = (big.meas["enc"] - sim) / np.tile(sig_enc, len(lags))[:, None]
    rows = np.arange(len(lags)) * n
    out = np.zeros(len(lags))
    for i, before, w, after in _switch_windows(runs, step_time(base.actuator)):
        step = z[(rows + i)[:, None], after].mean(axis=1) - z[(rows + i)[:, None], before] @ w
        out += step**2
    return out


def _whole(base, runs: Runs, sig_enc: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Whole-trial encoder chi-square of the base plant for each lag (one batch)."""
    n = len(runs.angle)
    big = runs.take(np.tile(np.arange(n), len(lags)))
    big.lag = np.repeat(lags, n)
    sim = simulate(base, [{}], big)["enc"][0]
    z = (big.meas["enc"] - sim) / np.tile(sig_enc, len(lags))[:, None]
    return np.nansum(z**2, axis=1).reshape(len(lags), n).sum(axis=1)


def fit_timing(base, runs: Runs, sig_enc: np.ndarray, pinned: float | None = None) -> Timing:
    """The lag in [0, 1] that best replays the encoder (coarse grid, then a fine one); the pinned lag when
    the log declares one (a map's [log] command, seagen's own logs), with a warning when the data clearly
    disagree."""
    chi = dict(zip(COARSE.tolist(), _profile(base, runs, sig_enc, COARSE).tolist(), strict=True))
    best = min(chi, key=chi.__getitem__)
    fine = np.clip(np.linspace(best - FINE_HALF, best + FINE_HALF, FINE_N), 0.0, 1.0)
    fine = np.unique(np.round(fine, 4))
    chi.update(zip(fine.tolist(), _profile(base, runs, sig_enc, fine).tolist(), strict=True))
    best = float(min(chi, key=chi.__getitem__))
    d = np.diff(runs.t, axis=1)[runs.mask[:, 1:]]
    period = float(np.median(d)) if d.size else 1.0 / base.actuator.loop_hz  # no two samples: the loop's
    # last, the whole-trial encoder chi-square within +-POLISH_S of it: at high rates a sample period is
    # short and the steps are the encoder's rounding; a band this narrow keeps missing physics from
    # pulling the lag far
    half = POLISH_S / max(period, 1e-6)
    band = np.unique(np.round(np.clip(best + np.linspace(-half, half, POLISH_N), 0.0, 1.0), 4))
    # a 500 Hz log's period summed in floating point (t += 1 ms) is 2.0000000000000018 ms: still 500 Hz
    if period <= POLISH_MAX_PERIOD_S + SNAP_S and len(band) > 1:
        best = float(band[int(np.argmin(_whole(base, runs, sig_enc, band)))])
    out = Timing(best if pinned is None else float(pinned), best, pinned, period, chi)
    if pinned is not None:
        # the polish may end between the grids' lags: score both on the switch steps
        missing = np.array([lag for lag in sorted({float(pinned), best}) if lag not in chi])
        if missing.size:
            chi.update(zip(missing.tolist(), _profile(base, runs, sig_enc, missing).tolist(), strict=True))
        worse = chi[float(pinned)] - chi[best]
        if worse > DISAGREE_CHI2 and abs(best - float(pinned)) >= 0.25:
            name = NAMES.get(float(pinned), f"lag {pinned}")
            out.warning = (
                f"the log declares the command '{name}' (lag {float(pinned):g}) but the data fit lag "
                f"{best:.2f} ({NAMES.get(round(best), '')}; switch-step chi-square {chi[best]:.4g} vs "
                f"{chi[float(pinned)]:.4g}); the replay uses the declared one: check the map's [log] command "
                "(timing.json)"
            )
    return out


MIN_SEGMENT_S = 0.05  # switches closer than this share one time shift
TIMING_CUT = 0.8  # share of the held-out chi-square above the floor that shifted switches must explain


def switch_shifts(runs: Runs, sim: dict[str, np.ndarray], sig: dict[str, np.ndarray], channels) -> tuple:
    """How much of the residual a time shift of the command switches explains (each segment between
    switches >= MIN_SEGMENT_S apart shifted by at most one sample period): residual ~ -dx_sim/dt * shift,
    fitted in noise units over `channels`. Returns (chi2 before, chi2 after, largest |shift| in s)."""
    from seagen.discrepancy.replay import SWITCH_V

    twin = dataclasses.replace(runs, meas={c: sim[c] for c in runs.meas})
    ts = runs.timing_sigma()
    unit = {c: 1.0 / np.sqrt(sig[c][:, None] ** 2 + ts[c] ** 2) for c in channels}
    z = {c: (runs.meas[c] - sim[c]) * unit[c] for c in channels}
    dz = {c: -twin.speed(c) * unit[c] for c in channels}  # d(residual)/d(shift), noise units per s
    before = after = worst = 0.0
    for i in range(len(runs.angle)):
        m = np.flatnonzero(runs.mask[i])
        t = runs.t[i, m]
        period = float(np.median(np.diff(t))) if len(m) > 1 else 0.0
        seg = np.zeros(len(m), dtype=int)
        last = -np.inf
        for j in np.flatnonzero(np.abs(np.diff(runs.volts[i, m])) > SWITCH_V) + 1:
            if t[j] - last >= MIN_SEGMENT_S:
                seg[j:] += 1
                last = t[j]
        for s in range(seg.max() + 1):
            cols = m[seg == s]
            y = np.concatenate([z[c][i, cols] for c in channels])
            x = np.concatenate([dz[c][i, cols] for c in channels])
            ok = np.isfinite(x) & np.isfinite(y)
            x, y = x[ok], y[ok]
            d = 0.0 if s == 0 else float(np.clip(x @ y / max(float(x @ x), 1e-300), -period, period))
            before += float(y @ y)
            after += float(((y - x * d) ** 2).sum())
            worst = max(worst, abs(d))
    return before, after, worst


def timing_problem(base, held: Runs, sig: dict[str, np.ndarray], floor: float, tim: Timing) -> bool:
    """Whether the base's held-out residual is mostly switches at the wrong instant (>= TIMING_CUT of its
    chi-square above the noise floor explained by shifting them by at most a sample period); if so the
    words go into tim.problem."""
    from seagen.discrepancy.residuals import SCORE_CHANNELS, n_scored

    sim = {c: v[0] for c, v in simulate(base, [{}], held).items()}
    before, after, worst = switch_shifts(held, sim, sig, SCORE_CHANNELS)
    excess = before - floor**2 * n_scored(held)
    cut = (before - after) / excess if excess > 0 else 0.0
    if cut < TIMING_CUT:
        return False
    tim.problem = (
        f"the residual is concentrated at the command switches: shifting them by at most one sample period "
        f"(up to {worst * 1000:.2f} ms) explains {cut:.0%} of it above the noise floor. This is the log's "
        "timing (which interval a logged command covers, a clock or a loop that does not log when the "
        "command was applied), not physics: nothing was fitted. Check the map's [log] command and the time "
        "column"
    )
    return True
