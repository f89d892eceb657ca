"""Candidate effects, their bounded parameter boxes, batched screening and least-squares fitting."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from seagen.discrepancy.replay import ParamSet, Runs, simulate
from seagen.discrepancy.residuals import SCORE_CHANNELS, chi2_per_trial, zscores
from seagen.plant import PlantConfig
from seagen.plant.config import CATALOGUE

# Fit box per effect parameter: (low, high, log-scaled). Realistic for a compact SEA; wide on purpose.
SPACE: dict[str, dict[str, tuple[float, float, bool]]] = {
    "actuator_friction": {"force_n": (0.2, 8.0, True), "reverse_ratio": (0.2, 1.2, False)},
    "linkage_friction": {"c0_n": (-1.5, 2.0, False), "c1_n": (-3.0, 3.0, False), "c2_n": (-3.0, 3.0, False)},
    "viscous_friction": {"b_n_s_per_mm": (0.005, 1.0, True)},
    "stribeck_friction": {"extra_static_n": (0.1, 5.0, True), "v_s_mm_s": (0.05, 5.0, True)},
    "series_compliance": {"k_n_per_mm": (3.0, 300.0, True), "beta_mm_per_n2": (0.0, 0.03, False)},
    "backlash": {"half_width_mm": (0.005, 0.4, True)},
    "spring_preload": {"force_n": (-4.0, 4.0, False)},
    "spring_nonlinearity": {"k3_n_per_mm3": (0.002, 0.6, True)},
    "pot_voltage_drop": {"counts_per_unit_current": (5.0, 600.0, True), "time_constant_s": (0.01, 0.8, True)},
    "load_cell_offset": {"offset_n": (-4.0, 4.0, False)},
    "transport_delay": {"delay_s": (0.001, 0.12, True)},
}
GRID = {1: 9, 2: 5, 3: 3}  # screening points per dimension
POLISH_NFEV = 6  # least-squares evaluations per polished candidate


@dataclass
class Candidate:
    """One effect or a pair: its names, parameter layout and current best point (unit coordinates)."""

    names: tuple[str, ...]
    u: np.ndarray
    chi2_fit: float = np.inf
    tag: str = ""  # appended to the label (e.g. ' (joint recalibration)')

    @property
    def keys(self) -> list[tuple[str, str]]:
        """(effect, parameter) per coordinate."""
        return [(e, p) for e in self.names for p in SPACE[e]]

    def params(self, u: np.ndarray | None = None) -> ParamSet:
        """Parameter set at unit point u (default: the best one)."""
        u = self.u if u is None else u
        out: ParamSet = {e: {} for e in self.names}
        for (e, p), x in zip(self.keys, np.clip(u, 0, 1), strict=True):
            lo, hi, log = SPACE[e][p]
            out[e][p] = float(lo * (hi / lo) ** x if log else lo + (hi - lo) * x)
        return out

    @property
    def label(self) -> str:
        """Human name: effects joined by '+', then the tag."""
        return "+".join(self.names) + self.tag


def missing_effects(cfg: PlantConfig) -> list[str]:
    """Catalogue effects switched off in cfg (pot_noise is a noise model, not a candidate)."""
    return [e for e in CATALOGUE if not cfg.on(e)]


def present_effects(cfg: PlantConfig) -> list[str]:
    """Catalogue effects switched on in cfg whose parameters can be recalibrated (not pot_noise)."""
    return [e for e in CATALOGUE if cfg.on(e)]


def to_unit(effect: str, param: str, value: float) -> float:
    """Inverse of the unit-box mapping of SPACE (clipped to the box)."""
    lo, hi, log = SPACE[effect][param]
    x = np.log(max(value, 1e-12) / lo) / np.log(hi / lo) if log else (value - lo) / (hi - lo)
    return float(np.clip(x, 0, 1))


def joint_recalibration(cfg: PlantConfig, fit: Runs, sigma: dict, nfev: int) -> Candidate | None:
    """Every present effect's parameters re-fitted together from cfg's values (least squares only: too
    many dimensions for a grid); None with fewer than two present effects."""
    present = present_effects(cfg)
    if len(present) < 2:
        return None
    c = Candidate(
        tuple(present), np.concatenate([start(cfg, e).u for e in present]), tag=" (joint recalibration)"
    )
    c.chi2_fit = float(objective(cfg, [c.params()], fit, sigma).sum())
    polish(cfg, c, fit, sigma, nfev=nfev)
    return c


def start(cfg: PlantConfig, effect: str) -> Candidate:
    """A single-effect candidate: at cfg's values when the effect is on (recalibration), else mid-box."""
    if not cfg.on(effect):
        return Candidate((effect,), np.full(len(SPACE[effect]), 0.5))
    eff = cfg.effect(effect)
    return Candidate((effect,), np.array([to_unit(effect, p, float(getattr(eff, p))) for p in SPACE[effect]]))


def objective(cfg: PlantConfig, sets: list[ParamSet], runs: Runs, sigma: dict) -> np.ndarray:
    """Chi-square per set and trial, shape (len(sets), n_trials)."""
    return chi2_per_trial(zscores(runs, simulate(cfg, sets, runs), sigma))


def _grid(c: Candidate, center: np.ndarray, half: float) -> list[np.ndarray]:
    """A regular grid in the candidate's unit box around center."""
    d = len(c.keys)
    axes = [np.clip(np.linspace(x - half, x + half, GRID[min(d, 3)]), 0, 1) for x in center]
    return [np.array(p) for p in itertools.product(*axes)]


def screen(
    cfg: PlantConfig,
    cands: list[Candidate],
    runs: Runs,
    sigma: dict,
    rounds: int = 3,
    half0: float = 0.5,
    beam: int = 1,
) -> None:
    """Zooming grid search for all candidates at once (one batched replay per round), half-width half0.

    Each candidate keeps its `beam` best distinct points and zooms around all of them (a multi-start
    search: the stick-slip and compliance objectives have narrow valleys and flat steps)."""
    centers = {id(c): [c.u] for c in cands}
    half = half0
    for _ in range(rounds):
        pts = [(c, u) for c in cands for u in _unique(p for x in centers[id(c)] for p in _grid(c, x, half))]
        chi = objective(cfg, [c.params(u) for c, u in pts], runs, sigma).sum(axis=1)
        for c in cands:
            idx = sorted((i for i, (cc, _) in enumerate(pts) if cc is c), key=lambda i: chi[i])
            centers[id(c)] = [pts[i][1] for i in idx[:beam]]
            if chi[idx[0]] < c.chi2_fit:
                c.u, c.chi2_fit = pts[idx[0]][1], float(chi[idx[0]])
        half /= 2.5


def _unique(points) -> list[np.ndarray]:
    """Points without repeats (overlapping grids of a beam share points)."""
    out: dict[bytes, np.ndarray] = {}
    for p in points:
        out.setdefault(np.round(p, 9).tobytes(), p)
    return list(out.values())


def _residual_vectors(cfg: PlantConfig, c: Candidate, us: list[np.ndarray], runs: Runs, sigma: dict):
    """Flattened residual vector (scored channels, real samples) for every unit point in us."""
    z = zscores(runs, simulate(cfg, [c.params(u) for u in us], runs), sigma)
    return [np.concatenate([z[ch][k][runs.mask] for ch in SCORE_CHANNELS]) for k in range(len(us))]


def polish(cfg: PlantConfig, c: Candidate, runs: Runs, sigma: dict, nfev: int = POLISH_NFEV) -> None:
    """Refine a candidate with scipy least_squares; value and forward-difference Jacobian in one batch."""
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
    step = 1e-3

    def both(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = np.asarray(u, float).tobytes()
        if key not in cache:
            h = np.where(u + step <= 1, step, -step)
            us = [u] + [u + h[i] * np.eye(len(u))[i] for i in range(len(u))]
            r = _residual_vectors(cfg, c, us, runs, sigma)
            cache.clear()
            cache[key] = (r[0], np.stack([(r[i + 1] - r[0]) / h[i] for i in range(len(u))], axis=1))
        return cache[key]

    sol = least_squares(
        lambda u: both(u)[0], c.u, jac=lambda u: both(u)[1], bounds=(0, 1), max_nfev=nfev, x_scale=0.1
    )
    chi = float(np.sum(sol.fun**2))
    if chi < c.chi2_fit:
        c.u, c.chi2_fit = sol.x, chi
