"""The claim rule: a name is claimed only when its fit closes the gap where it acts, leaving no structure."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from seagen.discrepancy.replay import ParamSet, Runs, simulate
from seagen.discrepancy.residuals import SCORE_CHANNELS, channel_rms, zscores
from seagen.plant import PlantConfig

ACT_SHARE = 0.3  # a channel an effect acts on: its footprint there is >= this share of its largest channel's
CUT = 0.8  # share of the gap (RMS above the noise floor) the changes must close on those channels
OWN = 0.5  # ... and the change alone must close at least this share of what is left with it undone


@dataclass
class Evidence:
    """What a named change's fit does on the channels it acts on (held-out trials, noise sigmas)."""

    footprint: dict[str, float]  # RMS change of each channel when the change alone is undone
    before: dict[str, float]  # channel RMS of the base plant
    after: dict[str, float]  # channel RMS with every change
    floor: float  # the noise floor
    without: dict[str, float] = field(default_factory=dict)  # channel RMS with the change alone undone
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
    def own(self) -> float:
        """Share of the gap the change alone closes on those channels: from the RMS with it undone (the
        others kept) to the RMS with every change; 0 when undoing it leaves them at the noise floor."""
        if not self.channels:
            return 0.0
        gap = self._rms(self.without) - self.floor
        return 0.0 if gap <= 0 else float(1 - max(self._rms(self.after) - self.floor, 0.0) / gap)

    @property
    def ok(self) -> bool:
        """The rule: the change acts somewhere, the changes close >= CUT of the gap there, the change itself
        >= OWN of what is left without it (not a rider on the others), and no significant region is left."""
        return bool(self.channels) and self.cut >= CUT and self.own >= OWN and not self.structure

    def words(self) -> str:
        """Why a name is not claimed, in words ('' when it is)."""
        ch = self.channels
        if not ch:
            return "moves no channel"
        what = ", ".join(ch)
        if self.cut < CUT:
            return f"closes only {self.cut:.0%} of the gap on {what} (rule: >= {CUT:.0%})"
        if self.own < OWN:
            return (
                f"closes only {self.own:.0%} of the gap left on {what} without it (rule: >= {OWN:.0%}; "
                "the other changes do the rest)"
            )
        if self.structure:
            return f"leaves structure on {what} ({'; '.join(self.structure[:3])})"
        return ""


def footprints(
    base: PlantConfig, changes: ParamSet, runs: Runs, sigma: dict[str, np.ndarray]
) -> tuple[dict[str, dict[str, float]], dict[str, dict[str, float]]]:
    """Per change, with that change alone undone (an added effect removed, a recalibration back to the
    base's values) and the others kept: each scored channel's RMS change and its residual RMS (noise
    sigmas; one batched replay)."""
    names = list(changes)
    sets = [changes] + [{e: p for e, p in changes.items() if e != n} for n in names]
    z = zscores(runs, simulate(base, sets, runs), sigma)
    m = runs.mask
    fp = {
        n: {c: float(np.sqrt(np.mean((z[c][i + 1] - z[c][0])[m] ** 2))) for c in SCORE_CHANNELS}
        for i, n in enumerate(names)
    }
    return fp, {n: channel_rms({c: z[c][i + 1] for c in SCORE_CHANNELS}, m) for i, n in enumerate(names)}


def left_structure(table: pd.DataFrame, channels: list[str]) -> list[str]:
    """The significant regions of a region table (residuals.region_table) on those channels, in words."""
    sig = table[table["significant"] & table["channel"].isin(channels)]
    return [f"{r.channel} by {r.by} {r.region}, mean {r.mean_z:+.2f} sigma" for r in sig.itertuples()]


def evidence(
    footprint: dict[str, float],
    before: dict[str, float],
    after: dict[str, float],
    floor: float,
    table: pd.DataFrame,
    without: dict[str, float],
) -> Evidence:
    """The evidence of one change from its footprint, the channel RMS before, after and with it undone,
    and the region table of the final residual."""
    ev = Evidence(footprint, before, after, floor, without=without)
    ev.structure = left_structure(table, ev.channels)
    return ev
