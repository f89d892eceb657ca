"""Recalibration of the base's own parameters: plausible ranges, 1-sigma uncertainty, change lines."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from seagen.actuator import Actuator
from seagen.discrepancy.candidates import (
    at,
    box,
    from_params,
    held_in,
    jacobian_points,
    present_effects,
    residual_vectors,
    values,
)
from seagen.discrepancy.replay import ParamSet, Runs
from seagen.plant import PlantConfig
from seagen.plant.config import PAPER_POT_FULL_SCALE, counts_range

# Plausible values for a compact SEA like the paper's (documented in the README). The fit may move a
# parameter anywhere in its wider SPACE box; a value outside these ranges is reported as implausible.
# Parameters in pot counts (POT_SHARES' keys) are shares of the pot's full scale here (plausible_range).
PLAUSIBLE_SHARES: dict[str, dict[str, tuple[float, float]]] = {
    "actuator_friction": {"force_n": (0.5, 6.0), "reverse_ratio": (0.3, 1.0)},
    "linkage_friction": {"c0_n": (-1.0, 1.5), "c1_n": (-2.5, 2.5), "c2_n": (-2.5, 2.5)},
    "viscous_friction": {"b_n_s_per_mm": (0.01, 0.6)},
    "stribeck_friction": {"extra_static_n": (0.2, 4.0), "v_s_mm_s": (0.1, 3.0)},
    "series_compliance": {"k_n_per_mm": (8.0, 150.0), "beta_mm_per_n2": (0.0, 0.015)},
    "backlash": {"half_width_mm": (0.01, 0.3)},
    "spring_preload": {"force_n": (-3.0, 3.0)},
    "spring_nonlinearity": {"k3_n_per_mm3": (0.005, 0.3)},
    "pot_voltage_drop": {
        "counts_per_unit_current": (0.0048828125, 0.09765625),  # 20 to 400 counts of a 12-bit pot
        "time_constant_s": (0.02, 0.5),
    },
    "load_cell_offset": {"offset_n": (-3.0, 3.0)},
    "transport_delay": {"delay_s": (0.002, 0.1)},
}


def plausible_range(
    effect: str, param: str, scale: float = PAPER_POT_FULL_SCALE, act: Actuator | None = None
) -> tuple[float, float]:
    """(low, high) of a parameter's plausible range, for a pot of `scale` counts (the paper's by default), on
    the actuator `act` (a parameter at a design's scale times its design_factor; the paper's when None)."""
    return counts_range(effect, param, PLAUSIBLE_SHARES[effect][param], scale, act)


# The ranges in the plant's units on the paper's pot (20 to 400 counts per unit current on its 12-bit ADC).
PLAUSIBLE: dict[str, dict[str, tuple[float, float]]] = {
    e: {p: plausible_range(e, p) for p in ps} for e, ps in PLAUSIBLE_SHARES.items()
}
_UNIT_SUFFIX = (
    ("_n_s_per_mm", "N s/mm"),
    ("_n_per_mm3", "N/mm^3"),
    ("_n_per_mm", "N/mm"),
    ("_mm_per_n2", "mm/N^2"),
    ("_mm_s", "mm/s"),
    ("_mm", "mm"),
    ("_n", "N"),
    ("_s", "s"),
)


def unit_of(param: str) -> str:
    """The unit a parameter's name carries ('' for a ratio or a count)."""
    return next((u for suffix, u in _UNIT_SUFFIX if param.endswith(suffix)), "")


def plausible(
    effect: str, param: str, value: float, scale: float = PAPER_POT_FULL_SCALE, act: Actuator | None = None
) -> bool:
    """Whether value lies in the documented plausible range (for a pot of `scale` counts, on `act`)."""
    lo, hi = plausible_range(effect, param, scale, act)
    return lo <= value <= hi


DEAD_COLUMN = 1e-7  # a Jacobian column below this share of the largest one's norm: the data do not move it


def unit_sigmas(jac: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """1-sigma of each (box-normalised) parameter from the Jacobian, the covariance times `scale`: infinite
    for a parameter whose column is zero, exactly or numerically (the data do not move it; the
    pseudo-inverse alone would give it 0, "pinned")."""
    norms = np.linalg.norm(jac, axis=0)
    live = norms > DEAD_COLUMN * (norms.max() if norms.size else 0.0)
    out = np.full(jac.shape[1], np.inf)
    j = jac[:, live]
    out[live] = np.sqrt(np.clip(np.diag(np.linalg.pinv(j.T @ j)) * scale, 0, None))
    return out


def box_sigma(s: float, value: float, lo: float, hi: float, log: bool) -> float:
    """A box-normalised 1-sigma `s` (unit_sigmas) in the parameter's own unit at `value`: infinite stays
    infinite (a parameter the data do not exercise)."""
    if not math.isfinite(s):
        return math.inf
    return float(s * (value * math.log(hi / lo) if log else hi - lo))


def uncertainty(base: PlantConfig, params: ParamSet, fit: Runs, sigma: dict) -> dict[str, dict[str, float]]:
    """1-sigma of every fitted parameter from the Gauss-Newton covariance of the fitting trials."""
    cand = from_params(params, base)
    u = cand.u
    us, h = jacobian_points(u)
    r = residual_vectors(base, [(cand, us)], fit, sigma)[0]
    jac = np.stack([(r[i + 1] - r[0]) / h[i] for i in range(len(u))], axis=1)
    dof = max(len(r[0]) - len(u), 1)
    scale = max(float(np.sum(r[0] ** 2)) / dof, 1.0)  # inflate when the fit leaves more than noise
    sig_u = unit_sigmas(jac, scale)
    out: dict[str, dict[str, float]] = {e: {} for e in params}
    for (e, p), s in zip(cand.keys, sig_u, strict=True):
        out[e][p] = box_sigma(s, params[e][p], *box(e, p, cand.full_scale, cand.act))
    return out


def change_lines(
    effect: str,
    before: dict[str, float],
    after: dict[str, float],
    sig: dict,
    scale: float = PAPER_POT_FULL_SCALE,
    act: Actuator | None = None,
) -> list[str]:
    """'actuator_friction.force_n 3.60 -> 2.71 N, ±0.02' per parameter, flagged when implausible (for a
    pot of `scale` counts)."""
    out = []
    for p, v in after.items():
        u = unit_of(p)
        line = f"{effect}.{p} {before[p]:.4g} -> {v:.4g}{' ' + u if u else ''}, ±{sig.get(p, np.nan):.2g}"
        line += " (not pinned: the data do not exercise it)" if math.isinf(sig.get(p, 0.0)) else ""
        if not plausible(effect, p, v, scale, act):
            lo, hi = plausible_range(effect, p, scale, act)
            line += f" (OUTSIDE the plausible range {lo:g}..{hi:g})"
        out.append(line)
    return out


PIN_SHARE = 0.05  # a parameter is pinned when the data resolve a change of this share of it ...
PIN_SIGMAS = 3.0  # ... at this many noise-only sigmas (all present parameters fitted together)
OFF_ALPHA = 1e-6  # the base's parameters are off when the score test rejects them at this level (a rig
# log of the right base gave up to 28.6 for 8 parameters, p = 4e-4: timing and rounding are not noise)


@dataclass
class BaseCheck:
    """What the fitting trials say about the base's own parameters, at the base's values: each one's
    noise-only 1-sigma (all present parameters together), the ones the data cannot pin, and a score test
    of 'every parameter right' (the chi-square drop one Gauss-Newton step predicts, chi-square with k
    degrees of freedom when the base is right)."""

    sigma: dict[str, float] = field(default_factory=dict)  # 'effect.param' -> 1-sigma (its unit)
    unpinned: dict[str, float] = field(default_factory=dict)  # 'effect.param' -> 1-sigma / |value|
    score: float = 0.0
    p_value: float = 1.0

    @property
    def unexercised(self) -> list[str]:
        """The parameters the data do not move at all (1-sigma infinite): not pinned, whatever their value."""
        return [k for k, v in self.sigma.items() if math.isinf(v)]

    @property
    def off(self) -> bool:
        """Whether the data reject the base's parameter values (a mis-set base)."""
        return self.p_value < OFF_ALPHA


def json_safe(d: dict[str, float]) -> dict[str, float | None]:
    """The values, an infinite one (a parameter the data do not exercise) as None (JSON has no infinity)."""
    return {k: None if math.isinf(v) else v for k, v in d.items()}


def base_check(base: PlantConfig, fit: Runs, sigma: dict) -> BaseCheck:
    """The BaseCheck of base on the fitting trials (one batched replay: the base and a step per parameter).

    A mis-set parameter often moves every sample a little (a pot-drop gain 21 % off: ~0.1 noise sigma per
    sample, no region's mean above the region test's 0.25) yet the whole log resolves it (Gauss-Newton
    1-sigma 2 %): the score test sees what the region tests cannot."""
    present = tuple(present_effects(base))
    if not present:
        return BaseCheck()
    cand = at(present, {e: values(base, e) for e in present}, held_in(base, present), cfg=base)
    us, h = jacobian_points(cand.u)
    r = residual_vectors(base, [(cand, us)], fit, sigma)[0]
    jac = np.stack([(r[i + 1] - r[0]) / h[i] for i in range(len(us) - 1)], axis=1)
    sig_u = unit_sigmas(jac)
    live = np.isfinite(sig_u)  # the parameters the data move: the score test's degrees of freedom
    step, *_ = np.linalg.lstsq(jac[:, live], -r[0], rcond=None)
    score = float(np.sum(r[0] ** 2) - np.sum((r[0] + jac[:, live] @ step) ** 2))
    p_value = float(stats.chi2.sf(score, int(live.sum()))) if live.any() else 1.0
    out = BaseCheck(score=score, p_value=p_value)
    params = cand.params()
    for (e, p), s in zip(cand.keys, sig_u, strict=True):
        lo, hi, log = box(e, p, cand.full_scale, cand.act)
        v = params[e][p]
        sig = box_sigma(s, v, lo, hi, log)
        out.sigma[f"{e}.{p}"] = sig
        scale = abs(v) if v != 0 else hi - lo
        if PIN_SIGMAS * sig > PIN_SHARE * scale:
            out.unpinned[f"{e}.{p}"] = sig / scale
    return out
