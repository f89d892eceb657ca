"""Discovery when the catalogue runs out: search the term library, fit the best form, claim it on evidence."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from seagen.discrepancy.candidates import (
    POLISH_NFEV,
    Candidate,
    at,
    full_scale,
    held_in,
    objective,
    polish,
    screen,
)
from seagen.discrepancy.claims import Evidence, evidence, footprints
from seagen.discrepancy.recalibrate import uncertainty
from seagen.discrepancy.replay import ParamSet, Runs, simulate
from seagen.discrepancy.residuals import channel_rms, n_scored, region_table, rms, zscores
from seagen.discrepancy.terms import DENSE, LIBRARY, STARTS, TERM_SPACE, form_of
from seagen.plant import PlantConfig

DBIC_MIN = 10.0  # the held-out BIC gain needed to name a term: as for a catalogue effect (workflow.DBIC_MIN)
BEAM = 3  # start points of each term zoomed after the start grid
# the selected term's final zoom (unit-box half-width, rounds: its objective may come in steps, where least
# squares stalls) and polish
ZOOM, ZOOM_ROUNDS, REFINE_NFEV = 0.1, 6, 20
ZOOM_MAX = 4  # parameters the final zoom takes (3^4 points a centre; breakaway_friction has 4)
EDGE = 0.01  # a parameter within this share of its box from an end is at the edge (workflow.EDGE)
WORSE, WORSE_MIN = 1.1, 1.2  # no channel may end above WORSE x its RMS and WORSE_MIN sigmas (workflow)


@dataclass
class Discovery:
    """The term a discovery found (claimed or not), its fit and the evidence."""

    term: str
    form: str  # its form class (terms.CLASSES)
    params: dict[str, float]
    sigma: dict[str, float]
    claimed: bool
    why: str  # why it is not claimed ('' when claimed)
    rms_before: float  # held-out residual RMS (noise sigmas): the base's, the catalogue's best, the term's
    rms_catalogue: float
    rms_after: float
    floor: float
    z_after: dict[str, np.ndarray] = field(default_factory=dict)
    evidence: Evidence | None = None
    table: pd.DataFrame | None = None  # every term's fit and held-out BIC
    edge: list[str] = field(default_factory=list)
    basis: str = "held-out BIC and the claim rule"  # how it was found (the search, or the readings' lattice)
    with_change: ParamSet = field(default_factory=dict)  # the catalogue change fitted with it (anchored)

    @property
    def cut(self) -> float:
        """Share of the held-out gap to the noise floor the term closes (all channels)."""
        return float(1 - max(self.rms_after - self.floor, 0.0) / max(self.rms_before - self.floor, 1e-12))

    def formula(self) -> str:
        """The term's formula in the plant's signals."""
        return LIBRARY[self.term].formula

    def unlike(self) -> str:
        """The closest catalogue effect and how the term differs from it."""
        return LIBRARY[self.term].unlike


def _starts(c: Candidate) -> list[np.ndarray]:
    """The start grid of a term: DENSE points along its many-valley parameters, STARTS along the others."""
    axes = []
    for e, p in c.keys:
        n = DENSE.get((e, p), STARTS)
        axes.append((np.arange(n) + 0.5) / n)
    return [np.array(u) for u in itertools.product(*axes)]


def search(cfg: PlantConfig, fit: Runs, sig_f: dict) -> list[Candidate]:
    """Every term fitted alone on the plant cfg: a start grid (one batched replay), a zoom of its BEAM
    best starts, then least squares."""
    cands = [Candidate((t,), np.full(len(TERM_SPACE[t]), 0.5), full_scale=full_scale(cfg)) for t in LIBRARY]
    pts = [(c, u) for c in cands for u in _starts(c)]
    chi = objective(cfg, [c.params(u) for c, u in pts], fit, sig_f).sum(axis=1)
    starts: list[Candidate] = []
    for c in cands:
        idx = sorted((i for i, (cc, _) in enumerate(pts) if cc is c), key=lambda i: chi[i])[:BEAM]
        for i in idx:
            starts.append(Candidate(c.names, pts[i][1].copy(), float(chi[i]), full_scale=c.full_scale))
    screen(cfg, starts, fit, sig_f, rounds=3, half0=0.5 / 3)
    best: dict[tuple[str, ...], Candidate] = {}
    for s in starts:  # each term's best start
        if s.names not in best or s.chi2_fit < best[s.names].chi2_fit:
            best[s.names] = s
    out = list(best.values())
    polish(cfg, out, fit, sig_f, nfev=2 * POLISH_NFEV)
    return out


def anchored(cfg: PlantConfig, anchor: ParamSet, fit: Runs, sig_f: dict) -> list[Candidate]:
    """Every term fitted on the plant cfg with the catalogue's closest change `anchor` (an effect added or
    re-fitted, at its own fit): each term searched with the anchor held, then both polished together (a
    form that stands in for a catalogue effect: the truth has the effect's share in another shape)."""
    held_cfg = cfg
    for e, p in anchor.items():
        held_cfg = held_cfg.with_effect(e, True, **p)
    terms = search(held_cfg, fit, sig_f)
    pairs = [
        at(tuple(anchor) + t.names, {**anchor, **t.params()}, held_in(cfg, tuple(anchor)), cfg=cfg)
        for t in terms
    ]
    polish(cfg, pairs, fit, sig_f, nfev=2 * POLISH_NFEV)
    return pairs


def refine(cfg: PlantConfig, c: Candidate, fit: Runs, sig_f: dict) -> None:
    """The selected term fitted to convergence: a local zoom (derivative-free: stick-slip and quantisation
    are not smooth; up to ZOOM_MAX parameters), then REFINE_NFEV more least-squares evaluations."""
    if len(c.keys) <= ZOOM_MAX:
        screen(cfg, [c], fit, sig_f, rounds=ZOOM_ROUNDS, half0=ZOOM, beam=2)
    polish(cfg, [c], fit, sig_f, nfev=REFINE_NFEV)


PROFILE_H = 0.03  # unit-box step of the curvature stencil of profile_sigma


def profile_sigma(cfg: PlantConfig, c: Candidate, fit: Runs, sig_f: dict) -> dict[str, float]:
    """Each parameter's 1-sigma from the fit chi-square's curvature over +-PROFILE_H of its box (the others
    held; inflated by the reduced chi-square when above 1), in its unit: an objective in steps (stick-slip)
    gives a Gauss-Newton Jacobian of its jumps, far too sure; this wider stencil sees the valley's width."""
    from seagen.discrepancy.candidates import box

    u0, k = np.clip(c.u, PROFILE_H, 1 - PROFILE_H), len(c.keys)
    pts = [u0] + [u0 + s * PROFILE_H * np.eye(k)[i] for i in range(k) for s in (1, -1)]
    chi = objective(cfg, [c.params(u) for u in pts], fit, sig_f).sum(axis=1)
    scale = max(float(chi[0]) / max(n_scored(fit) - k, 1), 1.0)
    out: dict[str, float] = {}
    for i, (e, p) in enumerate(c.keys):
        if e != c.names[-1]:  # the term's own parameters (an anchor's come from Gauss-Newton)
            continue
        curv = (chi[1 + 2 * i] + chi[2 + 2 * i] - 2 * chi[0]) / PROFILE_H**2
        su = math.sqrt(2 * scale / curv) if curv > 0 else math.inf
        lo, hi, log = box(e, p, c.full_scale)
        v = c.params(u0)[e][p]
        out[p] = float(su * (v * math.log(hi / lo) if log else hi - lo))
    return out


def _table(cfg: PlantConfig, cands: list[Candidate], held: Runs, sig_h: dict) -> pd.DataFrame:
    """Held-out chi-square, BIC (k ln n) and RMS of the plant alone (row 0) and with each term."""
    k = np.array([0] + [len(c.keys) for c in cands])
    chi = objective(cfg, [{}] + [c.params() for c in cands], held, sig_h).sum(axis=1)
    n = n_scored(held)
    return pd.DataFrame(
        {
            "term": ["(none)"] + [c.names[-1] for c in cands],
            "with": ["-"] + ["+".join(c.names[:-1]) or "-" for c in cands],
            "form": ["-"] + [form_of(c.names[-1]) for c in cands],
            "k": k,
            "chi2_fit": [np.nan] + [c.chi2_fit for c in cands],
            "bic_held_out": chi + k * math.log(n),
            "rms_held_out": np.sqrt(chi / n),
        }
    )


def _edge(term: str, params: dict[str, float], scale: float) -> list[str]:
    """Parameters fitted within EDGE of an end of their box."""
    from seagen.discrepancy.candidates import box

    out = []
    for p, v in params.items():
        lo, hi, log = box(term, p, scale)
        u = math.log(v / lo) / math.log(hi / lo) if log and v > 0 else (v - lo) / (hi - lo)
        if u <= EDGE or u >= 1 - EDGE:
            out.append(p)
    return out


def _residual(cfg: PlantConfig, sets: list[ParamSet], runs: Runs, sig: dict) -> list[dict[str, np.ndarray]]:
    """Held-out residuals (noise sigmas) of the plant cfg with each parameter set."""
    z = zscores(runs, simulate(cfg, sets, runs), sig)
    return [{c: v[i] for c, v in z.items()} for i in range(len(sets))]


def discover(
    cfg: PlantConfig,
    fit: Runs,
    held: Runs,
    sig_f: dict,
    sig_h: dict,
    floor: float,
    labels: dict[str, np.ndarray],
    rms_catalogue: float,
    anchor: ParamSet | None = None,
) -> Discovery | None:
    """Search the term library on the plant cfg (the base with the claimed catalogue changes), select by
    held-out BIC (the best term must beat the plant alone by DBIC_MIN), fit its parameters with their
    1-sigma, and claim it only on the named effects' rule: no parameter at its box's edge, no channel made
    worse, and on the channels it acts on >= CUT of the gap closed and no significant region left. None
    when no term earns the BIC gain. With `anchor` (the catalogue's closest change, not claimed), every term
    is also fitted together with it (anchored); the anchor's parameters count in the BIC."""
    cands = search(cfg, fit, sig_f) + (anchored(cfg, anchor, fit, sig_f) if anchor else [])
    table = _table(cfg, cands, held, sig_h)
    order = np.argsort(table.bic_held_out.to_numpy(), kind="stable")
    base_bic = float(table.bic_held_out.iloc[0])
    if order[0] == 0 or float(table.bic_held_out.iloc[order[0]]) > base_bic - DBIC_MIN:
        return None
    win = cands[order[0] - 1]
    table = table.iloc[order].reset_index(drop=True)
    refine(cfg, win, fit, sig_f)
    term, found = win.names[-1], win.params()
    params = found[term]
    z0, z1 = _residual(cfg, [{}, found], held, sig_h)
    fp, without = footprints(cfg, found, held, sig_h)
    before, after = channel_rms(z0, held.mask), channel_rms(z1, held.mask)
    ev = evidence(fp[term], before, after, floor, region_table(held, z1, labels), without[term])
    gn = uncertainty(cfg, found, fit, sig_f)
    wide = profile_sigma(cfg, win, fit, sig_f)
    sig = {p: max(gn[term][p], wide[p]) for p in gn[term]}
    edge = _edge(term, params, win.full_scale)
    worse = [c for c in before if after[c] > max(WORSE * before[c], WORSE_MIN)]
    why = ""
    if edge:
        why = f"not claimed: {', '.join(edge)} at the edge of its search box (the fit is not a value)"
    elif worse:
        why = f"not claimed: it makes held-out {', '.join(worse)} worse"
    elif not ev.ok:
        why = f"not claimed: its fit {ev.words()}"
    shown = dict(params)
    if "phase_rad" in shown:  # its box spans two turns: reported in [0, 2 pi)
        shown["phase_rad"] = float(shown["phase_rad"] % (2 * math.pi))
    return Discovery(
        term,
        form_of(term),
        shown,
        sig,
        not why,
        why,
        rms(z0),
        rms_catalogue,
        rms(z1),
        floor,
        z1,
        ev,
        table,
        edge,
        with_change={e: p for e, p in found.items() if e != term},
    )


ON_LATTICE = 0.99  # share of a channel's readings on one lattice for it to count as read in steps
LATTICE = (("load_cell_n", "cell_quantisation", "step_n"), ("pot", "pot_quantisation", "step_counts"))


def lattice(runs: Runs, rms_now: float, floor: float) -> Discovery | None:
    """A channel read in steps coarser than its noise, from the readings themselves: >= ON_LATTICE of them
    on multiples of the smallest step q between successive readings, and q at least the noise sigma of its
    second differences (steps that size are the channel's noise: no residual shows them). A log written
    with fewer decimals than its noise is reported so too (it is read in steps). The pot's own unit count
    is no discovery (q >= its box's lowest step). None when no channel is."""
    from seagen.discrepancy.candidates import box

    for c, term, param in LATTICE:
        x = runs.meas[c][runs.mask]
        d = np.abs(np.diff(x))
        d = d[np.isfinite(d) & (d > 1e-9 * float(np.nanmax(np.abs(x), initial=0.0)))]  # not float rounding
        if not d.size:
            continue
        q = float(d.min())
        k = (x - x[0]) / q
        on = float(np.mean(np.abs(k - np.rint(k)) < 1e-6))
        d2 = x[2:] - 2 * x[1:-1] + x[:-2]
        noise = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6.0)
        lo = box(term, param, full_scale())[0]
        if on < ON_LATTICE or q < noise or q < lo:
            continue
        near = d[np.abs(d - q) < 0.01 * q]
        return Discovery(
            term,
            form_of(term),
            {param: q},
            {param: float(np.std(near))},
            True,
            "",
            rms_now,
            rms_now,
            rms_now,
            floor,
            basis=(
                f"{on:.1%} of the {c} readings on multiples of {q:.4g}, at least the noise sigma of their "
                f"second differences ({noise:.3g})"
            ),
        )
    return None


def with_term(cfg: PlantConfig, d: Discovery) -> PlantConfig:
    """cfg with the discovered term switched on at its fitted values, and the catalogue change fitted with
    it (what plant.toml carries)."""
    for e, p in d.with_change.items():
        cfg = cfg.with_effect(e, True, **p)
    return cfg.with_effect(d.term, True, **d.params)
