"""The claim rule: a name is claimed only when its fit closes the gap where it acts, leaving no structure."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from seagen.discrepancy.replay import ParamSet, Runs, simulate
from seagen.discrepancy.residuals import SCORE_CHANNELS, zscores
from seagen.plant import PlantConfig

ACT_SHARE = 0.3  # a channel an effect acts on: its footprint there is >= this share of its largest channel's
CUT = 0.8  # share of the gap (RMS above the noise floor) the changes must close on those channels
SHARE = 0.5  # the change's own footprint there must be at least this share of that gap (not a rider)


@dataclass
class Evidence:
    """What a named change's fit does on the channels it acts on (held-out trials, noise sigmas)."""

    footprint: dict[str, float]  # RMS change of each channel when the change alone is undone
    before: dict[str, float]  # channel RMS of the base plant
    after: dict[str, float]  # channel RMS with every change
    floor: float  # the noise floor
    structure: list[str] = field(default_factory=list)  # significant regions left there ('channel by region')

    @property
    def channels(self) -> list[str]:
        """The channels the change acts on."""
        top = max(self.footprint.values(), default=0.0)
        return [c for c, f in self.footprint.items() if top > 0 and f >= ACT_SHARE * top]

    @property
    def cut(self) -> float:
        """Share of the gap to the noise floor closed on those channels (1 when they had no gap)."""
        if not self.channels:
            return 0.0
        b, a = self._rms(self.before), self._rms(self.after)
        gap = b - self.floor
        return 1.0 if gap <= 0 else float(1 - max(a - self.floor, 0.0) / gap)

    def _rms(self, values: dict[str, float]) -> float:
        """RMS over the channels the change acts on."""
        return float(np.sqrt(np.mean([values[c] ** 2 for c in self.channels])))

    @property
    def share(self) -> float:
        """The change's own footprint on those channels over their gap before (inf when they had none)."""
        gap = self._rms(self.before) - self.floor if self.channels else 0.0
        return float("inf") if gap <= 0 else self._rms(self.footprint) / gap

    @property
    def ok(self) -> bool:
        """The rule: the change acts somewhere, carries >= SHARE of the gap there itself, the changes close
        >= CUT of it, and no significant region is left there."""
        return bool(self.channels) and self.share >= SHARE and self.cut >= CUT and not self.structure

    def words(self) -> str:
        """Why a name is not claimed, in words ('' when it is)."""
        ch = self.channels
        if not ch:
            return "moves no channel"
        what = ", ".join(ch)
        if self.share < SHARE:
            return (
                f"moves {what} by {self._rms(self.footprint):.2g} sigma, {self.share:.0%} of the gap there "
                f"(rule: >= {SHARE:.0%}; the gap is closed by the other changes)"
            )
        if self.cut < CUT:
            return f"closes only {self.cut:.0%} of the gap on {what} (rule: >= {CUT:.0%})"
        if self.structure:
            return f"leaves structure on {what} ({'; '.join(self.structure[:3])})"
        return ""


def footprints(
    base: PlantConfig, changes: ParamSet, runs: Runs, sigma: dict[str, np.ndarray]
) -> dict[str, dict[str, float]]:
    """Per change: each scored channel's RMS change (noise sigmas) when that change alone is undone (an
    added effect removed, a recalibration back to the base's values), the others kept (one batched replay)."""
    names = list(changes)
    sets = [changes] + [{e: p for e, p in changes.items() if e != n} for n in names]
    z = zscores(runs, simulate(base, sets, runs), sigma)
    m = runs.mask
    return {
        n: {c: float(np.sqrt(np.mean((z[c][i + 1] - z[c][0])[m] ** 2))) for c in SCORE_CHANNELS}
        for i, n in enumerate(names)
    }


def channel_rms_masked(z: dict[str, np.ndarray], mask: np.ndarray) -> dict[str, float]:
    """Residual RMS per scored channel over the real samples."""
    return {c: float(np.sqrt(np.mean(np.nan_to_num(z[c][mask]) ** 2))) for c in SCORE_CHANNELS}


def left_structure(table: pd.DataFrame, channels: list[str]) -> list[str]:
    """The significant regions of a region table (residuals.region_table) on those channels, in words."""
    sig = table[table["significant"] & table["channel"].isin(channels)]
    return [f"{r.channel} by {r.by} {r.region}, mean {r.mean_z:+.2f} sigma" for r in sig.itertuples()]


def evidence(
    footprint: dict[str, float], before: dict[str, float], after: dict[str, float], floor: float, table
) -> Evidence:
    """The evidence of one change from its footprint, the channel RMS before/after and the region table."""
    ev = Evidence(footprint, before, after, floor)
    ev.structure = left_structure(table, ev.channels)
    return ev
