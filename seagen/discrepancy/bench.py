"""Hidden-effect cases (the plant with effects switched on) and the benchmark of the workflow over seeds."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from seagen.actuator import Actuator, default_actuator
from seagen.data.logimport import own_timing
from seagen.data.protocol import PUSH_MOVES, Move, run_trials, scaled_move
from seagen.discrepancy.replay import ParamSet, Runs, runs_from_frames, simulate
from seagen.discrepancy.residuals import SCORE_CHANNELS, noise_sigma, zscores
from seagen.discrepancy.workflow import Result, identify
from seagen.geometry import geometry
from seagen.plant import PlantConfig
from seagen.plant.config import CATALOGUE, counts_range, pot_full_scale

# Ranges the hidden parameters are drawn from (realistic for the paper's actuator). Those of pot counts
# (POT_SHARES' keys) are shares of the pot's full scale here: 60 to 200 counts on a 12-bit pot.
TRUTH: dict[str, dict[str, tuple[float, float]]] = {
    "actuator_friction": {"force_n": (1.5, 4.0), "reverse_ratio": (0.4, 0.9)},
    "linkage_friction": {"c0_n": (-0.3, 0.3), "c1_n": (0.8, 1.8), "c2_n": (0.8, 1.8)},
    "viscous_friction": {"b_n_s_per_mm": (0.05, 0.3)},
    "stribeck_friction": {"extra_static_n": (0.8, 2.5), "v_s_mm_s": (0.3, 1.5)},
    "series_compliance": {"k_n_per_mm": (15.0, 60.0), "beta_mm_per_n2": (0.002, 0.008)},
    "backlash": {"half_width_mm": (0.03, 0.15)},
    "spring_preload": {"force_n": (0.5, 2.0)},
    "spring_nonlinearity": {"k3_n_per_mm3": (0.03, 0.12)},
    "pot_voltage_drop": {
        "counts_per_unit_current": (0.0146484375, 0.048828125),
        "time_constant_s": (0.05, 0.25),
    },
    "load_cell_offset": {"offset_n": (0.3, 1.0)},
    "transport_delay": {"delay_s": (0.01, 0.06)},
}
HIDEABLE = CATALOGUE
HARD_PAIRS = (
    ("viscous_friction", "pot_voltage_drop"),
    ("viscous_friction", "transport_delay"),
    ("pot_voltage_drop", "transport_delay"),
    ("series_compliance", "spring_nonlinearity"),
    ("backlash", "stribeck_friction"),
    ("actuator_friction", "load_cell_offset"),
)
N_CASE_ANGLES = 6  # the reduced protocol's contact angles (6 to 26 deg on the paper's 5 to 28 deg range)
# Quick test data: two brisk moves to high force (longest trial ~190 samples instead of ~345; the replay
# costs the same per step whatever the batch, so a data set's cost is its longest trial).
FAST_MOVES = ((4.0, 17.0, -7.0), (5.0, 12.0, -8.0))


@dataclass
class Case:
    """Measured runs with `hidden` effects switched on, and the base the workflow starts from."""

    runs: Runs
    base: PlantConfig
    hidden: ParamSet


def draw(effect: str, rng: np.random.Generator, act: Actuator | None = None) -> dict[str, float]:
    """Random parameters for a hidden effect of actuator `act` (the paper's when None; pot counts in its
    ADC's; forces, lengths and stiffnesses at its scale, like the search's boxes: design_factor), offset
    sign random."""
    act = act or default_actuator()
    fs = pot_full_scale(act)
    p = {k: float(rng.uniform(*counts_range(effect, k, span, fs, act))) for k, span in TRUTH[effect].items()}
    if effect == "load_cell_offset":
        p["offset_n"] *= float(rng.choice([-1.0, 1.0]))
    return p


def case_angles(act: Actuator | None = None) -> tuple[float, ...]:
    """The reduced protocol's contact angles: evenly from 1 deg above the linkage range's minimum to 2 deg
    below its top (those of the train split, every other one) of `act` (the paper's when None)."""
    geo = geometry(act or default_actuator())
    lo, hi = geo.angle_min_deg + 1.0, geo.angle_max_deg - 2.0
    return tuple(float(a) for a in np.linspace(lo, hi, N_CASE_ANGLES))


def case_moves(
    moves: tuple[tuple[float, float, float], ...] = PUSH_MOVES, act: Actuator | None = None
) -> list[Move]:
    """The reduced protocol: two trials at each of the six case_angles of `act`, cycling through `moves`,
    their volts scaled to its motor (volts_scale)."""
    n = len(moves)
    return [scaled_move(a, moves[(i + k) % n], act) for i, a in enumerate(case_angles(act)) for k in (0, 1)]


def case_frames(cfg: PlantConfig, seed: int, fast: bool = False, plant_cls=None) -> list[pd.DataFrame]:
    """The case_moves trials of the plant cfg (FAST_MOVES if `fast`), each frame with its trial number."""
    moves = case_moves(FAST_MOVES if fast else PUSH_MOVES, cfg.actuator)
    return [df.assign(trial=i) for i, df in enumerate(run_trials(cfg, moves, seed=seed, plant_cls=plant_cls))]


def measure(cfg: PlantConfig, seed: int, fast: bool = False, plant_cls=None) -> Runs:
    """A reduced data set (two trials at each of six angles, paper protocol) from the plant cfg."""
    return runs_from_frames([("sim", df) for df in case_frames(cfg, seed, fast, plant_cls)], own_timing())


def make_case(
    effects: tuple[str, ...],
    seed: int,
    default: PlantConfig | None = None,
    fast: bool = False,
    act: Actuator | None = None,
) -> Case:
    """Hide `effects` (random parameters) in the default plant (of actuator `act`, the paper's when None);
    the base has them switched off."""
    rng = np.random.default_rng(seed)
    default = default or PlantConfig(actuator=act or default_actuator())
    hidden = {e: draw(e, rng, default.actuator) for e in effects}
    truth, base = default, default
    for e, p in hidden.items():
        truth, base = truth.with_effect(e, True, **p), base.with_effect(e, False)
    return Case(measure(truth, seed=int(rng.integers(1 << 30)), fast=fast), base, hidden)


def effect_to_noise(case: Case) -> float:
    """RMS (noise sigmas) of the hidden effects' change to the noise-free signals, largest channel."""
    sim = simulate(case.base, [{}, case.hidden], case.runs)
    sig = noise_sigma(case.runs)
    z = zscores(case.runs, {c: sim[c][0] - sim[c][1] + case.runs.meas[c] for c in sim}, sig)
    return max(float(np.sqrt(np.mean(z[c][case.runs.mask] ** 2))) for c in SCORE_CHANNELS)


def run_case(kind: str, effects: tuple[str, ...], seed: int, act: Actuator | None = None) -> dict:
    """One benchmark row: what was hidden, what was named, the gap before and after (actuator `act`)."""
    case = make_case(effects, seed, act=act)
    t0 = time.perf_counter()
    res: Result = identify(case.runs, case.base)
    names = [n.name for n in res.effects]
    return {
        "kind": kind,
        "hidden": "+".join(effects) or "-",
        "seed": seed,
        "named": "+".join(names) or "-",
        "recalibrated": "+".join(n.name for n in res.recalibrated) or "-",
        "verdict": res.verdict,
        "first_correct": bool(effects) and bool(names) and names[0] in effects,
        "all_found": set(effects) <= set(names),
        "effect_to_noise": effect_to_noise(case) if effects else 0.0,
        "rms_before": res.rms_before,
        "rms_after": res.rms_after,
        "noise_floor": res.noise_floor,
        "seconds": time.perf_counter() - t0,
    }


def plan(seeds: int) -> list[tuple[str, tuple[str, ...], int]]:
    """Cases per seed: every hideable effect alone, the control, one random pair and one hard pair."""
    out: list[tuple[str, tuple[str, ...], int]] = []
    for s in range(seeds):
        rng = np.random.default_rng(10_000 + s)
        out += [("single", (e,), 100 * s + i) for i, e in enumerate(HIDEABLE)]
        out.append(("control", (), 100 * s + 50))
        pair = tuple(sorted(rng.choice(HIDEABLE, size=2, replace=False)))
        out.append(("pair", pair, 100 * s + 60))
        out.append(("pair", HARD_PAIRS[s % len(HARD_PAIRS)], 100 * s + 70))
    return out


def summarize(rows: pd.DataFrame) -> dict:
    """The goal numbers of the discrepancy benchmark from the per-case table."""
    single = rows[(rows.kind == "single") & (rows.effect_to_noise >= 3)]
    fixed = rows[rows.kind != "control"]
    return {
        "single_correct_rate": float(single.first_correct.mean()) if len(single) else float("nan"),
        "false_alarm_rate": float((rows[rows.kind == "control"].named != "-").mean()),
        "pair_found_rate": float(rows[rows.kind == "pair"].all_found.mean()),
        "rms_reduction": float(np.median(1 - fixed.rms_after / fixed.rms_before)),
        "residual_over_noise": float(np.median(fixed.rms_after / fixed.noise_floor)),
        "seconds_per_dataset": float(rows.seconds.median()),
        "cases": rows.to_dict(orient="records"),
    }


def chosen(case: tuple, only: tuple[str, ...] = ()) -> bool:
    """Whether a planned case (kind, hidden effects, ...) is among `only`: its kind or one of its hidden
    effects named there (every case when `only` is empty)."""
    return not only or case[0] in only or any(e in only for e in case[1])


def bench(seeds: int, jobs: int = 2, act: Actuator | None = None, only: tuple[str, ...] = ()) -> dict:
    """Run every planned case (in `jobs` processes; those `chosen` by `only`) on actuator `act` (the
    paper's when None), summarize."""
    todo = [(*c, act) for c in plan(seeds) if chosen(c, only)]
    return {
        "actuator": (act or default_actuator()).name,
        **summarize(pd.DataFrame(run_all(_run, todo, jobs))),
    }


def run_all(fn, todo: list, jobs: int) -> list[dict]:
    """fn over every item of todo in `jobs` worker processes (seagen.workers), in order, with a progress
    bar on stderr when it is a terminal."""
    from seagen.workers import run_in_workers

    return run_in_workers(fn, todo, jobs, desc="data sets", unit="set")


def _run(args: tuple[str, tuple[str, ...], int, Actuator | None]) -> dict:
    """Picklable wrapper of run_case."""
    return run_case(*args)
