"""Candidate effects, their bounded parameter boxes, batched screening and least-squares fitting."""

from __future__ import annotations

import itertools
import math
import threading
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from seagen.actuator import Actuator
from seagen.discrepancy.parallel import chunked
from seagen.discrepancy.rendezvous import Rendezvous
from seagen.discrepancy.replay import ParamSet, Runs, simulate
from seagen.discrepancy.residuals import SCORE_CHANNELS, chi2_per_trial, zscores
from seagen.discrepancy.terms import TERM_SPACE
from seagen.plant import PlantConfig
from seagen.plant.config import CATALOGUE, counts_range, pot_full_scale

# Fit box per effect parameter: (low, high, log-scaled). Realistic for a compact SEA; wide on purpose. Those
# at a design's scale (plant.config.DESIGN_UNITS: N, mm, N/mm, ...) are the paper's here, and a candidate
# searches them times design_factor of its actuator (the structure's stiffness as a multiple of the spring's,
# a backlash as a share of the spring's travel, a friction as a share of the force range).
SPACE: dict[str, dict[str, tuple[float, float, bool]]] = {
    "actuator_friction": {"force_n": (0.2, 8.0, True), "reverse_ratio": (0.2, 1.2, False)},
    "linkage_friction": {"c0_n": (-1.5, 2.0, False), "c1_n": (-3.0, 3.0, False), "c2_n": (-3.0, 3.0, False)},
    "viscous_friction": {"b_n_s_per_mm": (0.005, 1.0, True)},
    "stribeck_friction": {"extra_static_n": (0.1, 5.0, True), "v_s_mm_s": (0.05, 5.0, True)},
    "series_compliance": {"k_n_per_mm": (3.0, 300.0, True), "beta_mm_per_n2": (0.0, 0.03, False)},
    "backlash": {"half_width_mm": (0.005, 0.4, True)},
    "spring_preload": {"force_n": (-4.0, 4.0, False)},
    "spring_nonlinearity": {"k3_n_per_mm3": (0.002, 0.6, True)},
    # counts_per_unit_current: a share of the pot ADC's full scale here (plant.config.counts_range)
    "pot_voltage_drop": {
        "counts_per_unit_current": (0.001220703125, 0.146484375, True),
        "time_constant_s": (0.01, 0.8, True),
    },
    "load_cell_offset": {"offset_n": (-4.0, 4.0, False)},
    "transport_delay": {"delay_s": (0.001, 0.12, True)},
}
# Every box a candidate may use: the catalogue's and the term library's (searched only when the catalogue
# runs out: discover.py).
BOXES = {**SPACE, **TERM_SPACE}
# Boxes of parameters in pot counts are shares of the pot ADC's full scale (counts_range): in counts they
# follow the description's pot.adc_bits (5 to 600 counts per unit current on the paper's 12-bit ADC).
# Candidate.full_scale carries the counts.
# A recalibration holds these parameters at the base's values while the named effect is on too: both move
# the same thing (a constant friction offset on the shaft: linkage c0 and actuator friction F_c), so the
# data cannot tell them apart and only the other one is re-fitted.
CONFOUNDED = {("linkage_friction", "c0_n"): "actuator_friction"}
GRID = {1: 9, 2: 5, 3: 3}  # screening points per dimension
POLISH_NFEV = 6  # least-squares evaluations per polished candidate
STEP = 1e-3  # forward-difference step of the Jacobians (unit box)
NOT_FINITE = 1e3  # the residual (noise sigmas) least squares sees where a replay is not finite


def _act(cfg: PlantConfig | None) -> Actuator | None:
    """cfg's actuator, whose scale the boxes take (None: the paper's)."""
    return None if cfg is None else cfg.actuator


def full_scale(cfg: PlantConfig | None = None) -> float:
    """Counts of the pot ADC's full scale (2^adc_bits) of cfg's actuator (the paper's when None)."""
    return pot_full_scale((cfg or PlantConfig()).actuator)


def box(effect: str, param: str, scale: float, act: Actuator | None = None) -> tuple[float, float, bool]:
    """(low, high, log-scaled) of a parameter's box in the plant's units, for a pot of `scale` counts, on the
    actuator `act` (a parameter at a design's scale times its design_factor; the paper's when None)."""
    lo, hi, log = BOXES[effect][param]
    return (*counts_range(effect, param, (lo, hi), scale, act), log)


@dataclass
class Candidate:
    """One effect or a pair: its names, parameter layout and current best point (unit coordinates)."""

    names: tuple[str, ...]
    u: np.ndarray
    chi2_fit: float = np.inf
    tag: str = ""  # appended to the label (e.g. ' (joint recalibration)')
    held: frozenset[tuple[str, str]] = frozenset()  # (effect, parameter) kept at the base's value
    full_scale: float = field(default_factory=full_scale)  # pot ADC counts (counts_range)
    act: Actuator | None = None  # the design whose scale the boxes take (box); the paper's when None

    @property
    def keys(self) -> list[tuple[str, str]]:
        """(effect, parameter) per coordinate."""
        return [(e, p) for e in self.names for p in BOXES[e] if (e, p) not in self.held]

    def params(self, u: np.ndarray | None = None) -> ParamSet:
        """Parameter set at unit point u (default: the best one)."""
        u = self.u if u is None else u
        out: ParamSet = {e: {} for e in self.names}
        for (e, p), x in zip(self.keys, np.clip(u, 0, 1), strict=True):
            lo, hi, log = box(e, p, self.full_scale, self.act)
            out[e][p] = float(lo * (hi / lo) ** float(x) if log else lo + (hi - lo) * x)
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


def to_unit(effect: str, param: str, value: float, scale: float, act: Actuator | None = None) -> float:
    """Inverse of the unit-box mapping of SPACE for a pot of `scale` counts (clipped to the box)."""
    lo, hi, log = box(effect, param, scale, act)
    x = math.log(max(value, 1e-12) / lo) / math.log(hi / lo) if log else (value - lo) / (hi - lo)
    return float(np.clip(x, 0, 1))


def held_in(cfg: PlantConfig, names: tuple[str, ...]) -> frozenset[tuple[str, str]]:
    """The CONFOUNDED parameters a candidate of `names` holds: a recalibration's, its partner being on."""
    return frozenset(
        k
        for k, other in CONFOUNDED.items()
        if k[0] in names and cfg.on(k[0]) and (cfg.on(other) or other in names)
    )


def at(
    names: tuple[str, ...],
    params: ParamSet,
    held: frozenset = frozenset(),
    tag: str = "",
    cfg: PlantConfig | None = None,
) -> Candidate:
    """A candidate of `names` at the values in params (a full set for each effect but the held ones), on
    the plant `cfg` (its pot ADC scales the boxes of pot counts; the paper's when None)."""
    c = Candidate(names, np.zeros(0), tag=tag, held=held, full_scale=full_scale(cfg), act=_act(cfg))
    c.u = np.array([to_unit(e, p, params[e][p], c.full_scale, c.act) for e, p in c.keys])
    return c


def from_params(params: ParamSet, cfg: PlantConfig | None = None) -> Candidate:
    """A candidate at a fitted parameter set on the plant `cfg`; a parameter absent from it is held
    (CONFOUNDED)."""
    held = frozenset((e, p) for e in params for p in BOXES[e] if p not in params[e])
    return at(tuple(params), params, held, cfg=cfg)


def values(cfg: PlantConfig, effect: str) -> dict[str, float]:
    """cfg's values of an effect's fitted parameters."""
    return {p: float(getattr(cfg.effect(effect), p)) for p in BOXES[effect]}


def joint_recalibration(cfg: PlantConfig) -> Candidate | None:
    """Every present effect's parameters together, at cfg's values, to be polished (least squares only:
    too many dimensions for a grid; the polish sets its chi-square, never above the start's); None with
    fewer than two present effects."""
    present = tuple(present_effects(cfg))
    if len(present) < 2:
        return None
    return at(
        present, {e: values(cfg, e) for e in present}, held_in(cfg, present), " (joint recalibration)", cfg
    )


def start(cfg: PlantConfig, effect: str) -> Candidate:
    """A single-effect candidate: at cfg's values when the effect is on (recalibration), else mid-box."""
    if not cfg.on(effect):
        return Candidate(
            (effect,), np.full(len(BOXES[effect]), 0.5), full_scale=full_scale(cfg), act=_act(cfg)
        )
    return at((effect,), {effect: values(cfg, effect)}, held_in(cfg, (effect,)), cfg=cfg)


def pair(cfg: PlantConfig, a: Candidate, b: Candidate) -> Candidate:
    """a and b together, each at its own best point."""
    names = a.names + b.names
    return at(names, {**a.params(), **b.params()}, held_in(cfg, names), cfg=cfg)


def objective(cfg: PlantConfig, sets: list[ParamSet], runs: Runs, sigma: dict) -> np.ndarray:
    """Chi-square per set and trial, shape (len(sets), n_trials); infinite where a set's replay is not
    finite on a real sample (a term of the library driven out of its solver's range: never a fit). A batch
    is replayed in chunks over the processes of parallel.replays, when inside one."""
    return chunked(_chi, sets, cfg, runs, sigma)


def _chi(sets: list[ParamSet], cfg: PlantConfig, runs: Runs, sigma: dict) -> np.ndarray:
    """objective's chi-square per set and trial, from one batched replay of sets."""
    z = zscores(runs, simulate(cfg, sets, runs), sigma)
    chi = chi2_per_trial(z)
    bad = np.zeros(chi.shape, dtype=bool)
    for c in SCORE_CHANNELS:
        bad |= (~np.isfinite(z[c]) & runs.mask).any(axis=-1)
    return np.where(bad, np.inf, chi)


def _grid(
    c: Candidate, center: np.ndarray, half: float, hold: tuple[str, ...] = (), nudge: float = 0.0
) -> list[np.ndarray]:
    """A regular grid in the candidate's unit box around center; coordinates of effects in hold stay put,
    or, with nudge > 0, take three points within nudge x half of it."""
    free = [e not in hold for e, _ in c.keys]
    n = GRID[min(sum(free), 3)]
    axes = [
        np.clip(np.linspace(x - half, x + half, n), 0, 1)
        if f
        else np.clip(np.linspace(x - nudge * half, x + nudge * half, 3), 0, 1)
        if nudge
        else [x]
        for x, f in zip(center, free, strict=True)
    ]
    return [np.array(p) for p in itertools.product(*axes)]


def screen(
    cfg: PlantConfig,
    cands: list[Candidate],
    runs: Runs,
    sigma: dict,
    rounds: int = 3,
    half0: float = 0.5,
    beam: int = 1,
    hold: tuple[str, ...] = (),
    nudge: float = 0.0,
) -> None:
    """Zooming grid search for all candidates at once (one batched replay per round), half-width half0.

    Each candidate keeps its `beam` best distinct points and zooms around all of them (a multi-start
    search: the stick-slip and compliance objectives have narrow valleys and flat steps). The parameters
    of the effects in `hold` stay put (a pair's anchor, already fitted alone), or move within nudge x the
    half-width."""
    centers = {id(c): [c.u] for c in cands}
    half = half0
    for _ in range(rounds):
        pts = [
            (c, u)
            for c in cands
            for u in _unique(p for x in centers[id(c)] for p in _grid(c, x, half, hold, nudge))
        ]
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


def residual_vectors(
    cfg: PlantConfig, jobs: list[tuple[Candidate, list[np.ndarray]]], runs: Runs, sigma: dict
) -> list[list[np.ndarray]]:
    """Flattened residual vectors (scored channels, real samples) of every (candidate, unit points) job,
    all from one batched replay (in chunks over the processes of parallel.replays, when inside one)."""
    sets = [c.params(u) for c, us in jobs for u in us]
    flat = list(chunked(_flat, sets, cfg, runs, sigma))
    ends = np.cumsum([len(us) for _, us in jobs])
    return [flat[e - len(us) : e] for (_, us), e in zip(jobs, ends, strict=True)]


def _flat(sets: list[ParamSet], cfg: PlantConfig, runs: Runs, sigma: dict) -> np.ndarray:
    """The flattened residual vectors of sets (one row each), from one batched replay."""
    z = zscores(runs, simulate(cfg, sets, runs), sigma)
    flat = [np.concatenate([z[ch][k][runs.mask] for ch in SCORE_CHANNELS]) for k in range(len(sets))]
    return np.stack([np.where(np.isfinite(f), f, NOT_FINITE) for f in flat])  # out of range: a large misfit


def jacobian_points(u: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """u and its forward-difference neighbours (backward at the upper bound), and the signed steps."""
    h = np.where(u + STEP <= 1, STEP, -STEP)
    return [u] + [u + h[i] * np.eye(len(u))[i] for i in range(len(u))], h


def polish(
    cfg: PlantConfig, cands: list[Candidate], runs: Runs, sigma: dict, nfev: int = POLISH_NFEV
) -> None:
    """Refine candidates with scipy least_squares, one solver per candidate in its own thread; whenever
    every running solver waits for a value and Jacobian, one batched replay answers them all."""
    meet = Rendezvous(len(cands))
    errors: list[BaseException] = []
    # One solver computes at a time (between its requests): the solvers' own linear algebra in BLAS at once
    # from many threads made OpenBLAS's threads contend (5x the polish's CPU); each solver's numbers and the
    # batches (formed when every live solver waits) are the same either way.
    turn = threading.Lock()

    def ask(i: int, us: list[np.ndarray]) -> list[np.ndarray]:
        turn.release()
        try:
            return meet.ask(i, us)
        finally:
            turn.acquire()

    def run(i: int) -> None:
        turn.acquire()
        try:
            _least_squares(cands[i], nfev, lambda us: ask(i, us))
        except BaseException as exc:  # handed to the caller below
            errors.append(exc)
        finally:
            turn.release()
            meet.leave(i)

    threads = [threading.Thread(target=run, args=(i,), daemon=True) for i in range(len(cands))]
    for t in threads:
        t.start()
    meet.serve(lambda asked: residual_vectors(cfg, [(cands[i], us) for i, us in asked], runs, sigma))
    for t in threads:
        t.join()
    if errors:
        raise errors[0]


def _least_squares(c: Candidate, nfev: int, ask) -> None:
    """One bounded least-squares refinement of c; `ask(unit points)` returns their residual vectors."""
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def both(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = np.asarray(u, float).tobytes()
        if key not in cache:
            us, h = jacobian_points(u)
            r = ask(us)
            cache.clear()
            cache[key] = (r[0], np.stack([(r[i + 1] - r[0]) / h[i] for i in range(len(u))], axis=1))
        return cache[key]

    sol = least_squares(
        lambda u: both(u)[0], c.u, jac=lambda u: both(u)[1], bounds=(0, 1), max_nfev=nfev, x_scale=0.1
    )
    chi = float(np.sum(sol.fun**2))
    if chi < c.chi2_fit:
        c.u, c.chi2_fit = sol.x, chi
