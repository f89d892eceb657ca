"""The learned remainder: a small smooth correction on one measured channel when the catalogue runs out."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from seagen.discrepancy.replay import Runs, simulate
from seagen.discrepancy.residuals import n_scored, zscores
from seagen.discrepancy.signature import MIN_R2, features, profile
from seagen.plant import PlantConfig
from seagen.plant.config import LEARNED_CHANNELS, LEARNED_INPUTS
from seagen.plant.sim import learned_basis

# The plant signal that carries each dependence the signature names.
GROUP_INPUT = {
    "force": "force_n",
    "speed": "speed_mm_s",
    "direction": "speed_mm_s",
    "reversal": "speed_mm_s",
    "since_motion": "speed_mm_s",
    "current": "current",
    "angle": "contact_deg",
}
RIDGE = 1e-2  # ridge weight (chi-square units per unit coefficient^2): keeps the correction smooth
DBIC = 10.0  # same evidence bar as a named effect


@dataclass
class Learned:
    """A fitted remainder: its channel, inputs and what it did to the held-out residual."""

    channel: str
    inputs: list[str]
    scales: list[float]
    coef: list[float]
    z: dict[str, np.ndarray]  # held-out residual with the correction


def _inputs_for(prof_channel: dict[str, float]) -> list[str]:
    """The plant signals behind the dependences the signature found (all of them if it found none)."""
    named = [GROUP_INPUT[k] for k, r in prof_channel.items() if k in GROUP_INPUT and r >= MIN_R2]
    return [i for i in LEARNED_INPUTS if i in named] or list(LEARNED_INPUTS)


def _design(runs: Runs, rec: dict, inputs: list[str], scales: list[float], sigma: np.ndarray) -> np.ndarray:
    """Basis rows of the real samples, divided by each trial's noise sigma (the fit is in noise units)."""
    vals = {k: v[0][runs.mask] for k, v in rec.items()}
    s = np.broadcast_to(sigma[:, None], runs.mask.shape)[runs.mask]
    return learned_basis(inputs, scales, vals) / s[:, None]


def fit_learned(cfg: PlantConfig, fit: Runs, held: Runs, sig_f: dict, sig_h: dict) -> Learned | None:
    """Fit the correction on the fitting trials for each allowed channel; keep the held-out BIC winner."""
    rec_f: dict[str, np.ndarray] = {}
    rec_h: dict[str, np.ndarray] = {}
    z_f = {c: v[0] for c, v in zscores(fit, simulate(cfg, [{}], fit, rec_f), sig_f).items()}
    z_h = {c: v[0] for c, v in zscores(held, simulate(cfg, [{}], held, rec_h), sig_h).items()}
    prof = profile(z_f, fit, features(fit, cfg.motor, cfg.actuator.control.force_max_n))
    best, best_dbic = None, -DBIC
    for ch in LEARNED_CHANNELS:
        inputs = _inputs_for(prof[ch])
        scales = [max(float(np.nanpercentile(np.abs(rec_f[k][0][fit.mask]), 95)), 1e-6) for k in inputs]
        a = _design(fit, rec_f, inputs, scales, sig_f[ch])
        y = np.nan_to_num(z_f[ch][fit.mask])
        coef = np.linalg.solve(a.T @ a + RIDGE * np.eye(a.shape[1]), a.T @ y)
        zh = np.nan_to_num(z_h[ch][held.mask])
        after = zh - _design(held, rec_h, inputs, scales, sig_h[ch]) @ coef
        dbic = float(np.sum(after**2) - np.sum(zh**2)) + len(coef) * math.log(n_scored(held))
        if dbic < best_dbic:
            z = dict(z_h)
            z[ch] = z_h[ch].copy()
            z[ch][held.mask] = after
            best, best_dbic = Learned(ch, inputs, scales, [float(c) for c in coef], z), dbic
    return best


def with_learned(cfg: PlantConfig, learned: Learned) -> PlantConfig:
    """cfg with the learned_residual effect switched on at the fitted correction."""
    return cfg.with_effect(
        "learned_residual",
        True,
        channel=learned.channel,
        inputs=learned.inputs,
        scales=learned.scales,
        coef=learned.coef,
    )
