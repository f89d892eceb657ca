"""The blind forms' score (issue 39 item 3): each form of blindforms.py run once on the frozen discovery code.

`python -m seagen.discrepancy.blindbench [--set S] [--seed N] [--jobs J] [--json]`. Set 1: blindforms.py (run
once on 9b2d13e, out of sample; in-sample since: the terms added after it was read), set 2: blindforms2.py
(read only after the rule and the library were frozen again, FROZEN[2]; in-sample since the seven terms
after it), set 3: blindforms3.py (read only after the freeze FROZEN[3]). Per form: the class discovered and
whether it is claimed, right (the committed expected class) or a wrong claim, each true parameter against the
fitted one of the same unit within 3 sigma, the held-out gap cut of what plant.toml carries, seconds.
The rule and the term library were committed and frozen (FROZEN) before blindforms.py was read.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

import numpy as np
import pandas as pd

from seagen.discrepancy.bench import measure, run_all
from seagen.discrepancy.recalibrate import unit_of
from seagen.discrepancy.report import gap_cut
from seagen.discrepancy.workflow import identify

# the last commit of discover.py / terms.py / the claim rule before each blind set was read
FROZEN = {1: "9b2d13e", 2: "ada7c03", 3: "e3128f6"}
MODULES = {
    1: "seagen.discrepancy.blindforms",
    2: "seagen.discrepancy.blindforms2",
    3: "seagen.discrepancy.blindforms3",
}
WITHIN = 3.0  # a parameter counts as recovered within this many of its sigmas
TARGET = {"right_claimed": 0.7, "wrong_claims": 0, "median_gap_cut": 0.9}
# Which fitted term parameter stands for which true one (written after reading blindforms.py, for the
# score only: the rule never sees it): form -> {true key: (term, its parameter, true value -> term's value)}
# (a list of them when more than one term can stand for it: the discovered term's is scored).
# A blind phase is that of a sine, a term's that of a cosine: sin(a + p) = cos(a + p - pi/2).
Mapping = dict[str, dict[str, Any]]
PARAMS: Mapping = {
    "thread_error": {
        "amplitude_mm": ("lead_error", "amplitude_mm", None),
        "period_mm": ("lead_error", "period_mm", None),
        "phase_rad": ("lead_error", "phase_rad", lambda p, _: (p - math.pi / 2) % (2 * math.pi)),
    },
    "gear_detent": {
        "amplitude_n": ("cogging", "force_n", None),
        "period_mm": ("cogging", "period_mm", None),
        "phase_rad": ("cogging", "phase_rad", lambda p, _: (p - math.pi / 2) % (2 * math.pi)),
    },
    "spring_relaxation": {"drop": ("spring_drift", "share", lambda d, _: -d)},
    "lagged_breakaway": {
        "fs_n": [("rate_friction", "extra_n", None), ("breakaway_friction", "extra_n", None)],
        "vs_mm_s": ("breakaway_friction", "v_s_mm_s", None),
        "tau_s": [
            ("rate_friction", "time_constant_s", None),
            ("breakaway_friction", "time_constant_s", None),
        ],
    },
    "progressive_spring": {"k2_n_per_mm2": ("spring_poly", "k2_n_per_mm2", None)},
    "pot_lag": {
        "tau_s": [("pot_lag", "time_constant_s", None), ("pot_reading_lag", "time_constant_s", None)]
    },
    "cell_quantised": {"step_n": ("cell_quantisation", "step_n", None)},
    "cell_saturation": {
        "f_sat_n": [("cell_saturation", "limit_n", None), ("cell_soft_saturation", "limit_n", None)]
    },
    # the terms added after set 1 was read (in-sample)
    "spring_hysteresis": {
        "h_n": ("spring_bouc_wen", "force_n", None),
        "width_mm": ("spring_bouc_wen", "width_mm", None),
    },
    "cell_hysteresis": {
        "h_n": ("cell_hysteresis", "force_n", None),
        "width_n": ("cell_hysteresis", "width_n", None),
    },
    "pot_clamp": {"sat_counts": ("pot_saturation", "limit_counts", None)},
}
# Set 2's (written after the freeze at ada7c03, once blindforms2.py was read; for the score only). Only a
# true parameter with the same meaning as a term's is scored (a gear mesh error's first harmonic is
# lead_error's; a Bouc-Wen seat's force k_h z0 and width z0 are spring_bouc_wen's h and w; a two-branch
# cell's half height is cell_hysteresis's h; a soft rail's asymptote is cell_soft_saturation's L).
PARAMS2: Mapping = {
    "gear_mesh_error": {
        "amplitude_mm": ("lead_error", "amplitude_mm", None),
        "period_mm": ("lead_error", "period_mm", None),
        "phase_rad": ("lead_error", "phase_rad", lambda p, _: (p - math.pi / 2) % (2 * math.pi)),
    },
    "bouc_wen_spring": {
        "k_h_n_per_mm": ("spring_bouc_wen", "force_n", lambda k, t: k * t["z0_mm"]),
        "z0_mm": ("spring_bouc_wen", "width_mm", None),
    },
    "cell_loop_hysteresis": {"half_height_n": ("cell_hysteresis", "force_n", None)},
    "cell_adc_truncation": {"step_n": ("cell_quantisation", "step_n", None)},
    "amp_soft_rail": {"asymptote_n": ("cell_soft_saturation", "limit_n", None)},
    # the terms added after set 2 was read (in-sample): the true laws' parameters of the same meaning
    "load_friction": {"mu": ("load_friction", "mu", None)},
    "rough_spot": {
        "extra_n": ("position_friction", "extra_n", None),
        "center_mm": ("position_friction", "center_mm", None),
        "width_mm": ("position_friction", "width_mm", None),
    },
    "coil_contact": {
        "extra_k_n_per_mm": ("spring_knee", "dk_n_per_mm", None),
        "onset_mm": ("spring_knee", "onset_mm", None),
    },
    "current_limit": {"limit_share": ("current_limit", "limit_share", None)},
    "pot_gear_ripple": {"amplitude_counts": ("pot_ripple", "amplitude_counts", None)},
}
# Set 3's (written after the freeze at e3128f6, once blindforms3.py was read; for the score only). A true
# parameter is scored only where a term's has its meaning: a thread's or carrier's first harmonic is
# lead_error's (a sine phase is a cosine's + pi/2; the carrier's is a cosine), a ball-pass period is a
# periodic term's period, a pot track's ripple amplitude is pot_ripple's, a supply sag's time constant a
# pot drift's, a cell's play half height cell_hysteresis's h, an Iwan spring's total slip force the
# Bouc-Wen spring's h, a second-order filter's low-frequency delay a first-order lag's time constant.
PARAMS3: Mapping = {
    "screw_pitch_error": {
        "amplitude_mm": ("lead_error", "amplitude_mm", None),
        "period_mm": ("lead_error", "period_mm", None),
        "phase_rad": ("lead_error", "phase_rad", lambda p, _: (p - math.pi / 2) % (2 * math.pi)),
    },
    "carrier_runout": {
        "amplitude_mm": ("lead_error", "amplitude_mm", None),
        "period_mm": ("lead_error", "period_mm", None),
        "phase_rad": ("lead_error", "phase_rad", None),
    },
    "pot_track_ripple": {"amplitude_counts": ("pot_ripple", "amplitude_counts", None)},
    "bearing_defect": {"period_mm": [("cogging", "period_mm", None), ("lead_error", "period_mm", None)]},
    "pot_supply_sag": {"tau_s": ("pot_drift", "time_constant_s", None)},
    "load_friction": {"mu": ("load_friction", "mu", None)},
    "ageing_friction": {
        "extra_n": [("breakaway_friction", "extra_n", None), ("rate_friction", "extra_n", None)]
    },
    "cell_play_hysteresis": {"half_height_n": ("cell_hysteresis", "force_n", None)},
    "iwan_spring": {"friction_n": ("spring_bouc_wen", "force_n", None)},
    "coil_seating": {"onset_mm": ("spring_knee", "onset_mm", None)},
    "cell_filter2": {"lag_s": ("cell_lag", "time_constant_s", None)},
    "cell_quantised": {"step_n": ("cell_quantisation", "step_n", None)},
    "drive_current_limit": {"current_limit": ("current_limit", "limit_share", None)},
}
PARAMS_OF = {1: PARAMS, 2: PARAMS2, 3: PARAMS3}


def _params(name: str, truth: dict[str, float], d, mapping: Mapping | None = None) -> list[dict]:
    """Each mapped true parameter against the discovered term's fit: value, sigma, within WITHIN sigma."""
    out = []
    for key, alts in (PARAMS if mapping is None else mapping).get(name, {}).items():
        alts = alts if isinstance(alts, list) else [alts]
        match = [a for a in alts if d is not None and d.term == a[0]]
        if not match or key not in truth:
            continue
        term, p, to = match[0]
        want = to(truth[key], truth) if to else truth[key]
        got, sig = d.params[p], d.sigma.get(p, math.nan)
        err = got - want
        if p == "phase_rad":
            err = (err + math.pi) % (2 * math.pi) - math.pi
        out.append(
            {
                "param": f"{term}.{p}",
                "true": want,
                "fitted": got,
                "sigma": sig,
                "unit": unit_of(p),
                "within": bool(abs(err) <= WITHIN * sig),
                "rel_error": abs(err) / abs(want) if want else math.nan,
            }
        )
    return out


def _module(which: int):
    """The blind set's module (imported only when that set runs)."""
    import importlib

    return importlib.import_module(MODULES[which])


def run_blind(name: str, seed: int, fast: bool = False, which: int = 1) -> dict:
    """One blind case: simulate the form's data, identify once, score against the committed expectation."""
    cls, truth, base, expect = _module(which).blind_case(name, seed)
    runs = measure(truth, seed=seed, fast=fast, plant_cls=cls)
    t0 = time.process_time()
    res = identify(runs, base)
    cpu = time.process_time() - t0
    d = res.discovered
    expected = expect["expected_class"]
    claimed = d is not None and d.claimed
    form = d.form if d is not None else "-"
    right = claimed and form == expected if expected != "other" else not claimed
    pars = _params(name, expect["truth"], d if claimed else None, PARAMS_OF[which])
    return {
        "form": name,
        "seed": seed,
        "expected_class": expected,
        "discovered": d.form if d else "-",
        "term": d.term if d else "-",
        "claimed": claimed,
        "right": bool(right),
        "wrong_claim": bool(claimed and form != expected),
        "why": d.why if d else "",
        "verdict": res.verdict,
        "catalogue_claims": [n.name for n in res.effects + res.recalibrated if n.claimed],
        "params": pars,
        "params_within": sum(p["within"] for p in pars),
        "params_scored": len(pars),
        "gap_cut": gap_cut(res.rms_before, res.rms_learned, res.noise_floor),
        "rms_before": res.rms_before,
        "rms_final": res.rms_learned,
        "floor": res.noise_floor,
        "cpu_s": cpu,
        "truth": expect["truth"],
        "fitted": d.params if d else {},
    }


def summarize(rows: pd.DataFrame, which: int = 1) -> dict:
    """The issue's numbers: right and claimed, wrong claims, median gap cut (classed forms), parameters."""
    classed = rows[rows.expected_class != "other"]
    return {
        "set": which,
        "frozen_at": FROZEN[which],
        "cases": len(rows),
        "right_claimed": float(rows.right.mean()),
        "right_claimed_classed": float(classed.right.mean()) if len(classed) else math.nan,
        "wrong_claims": int(rows.wrong_claim.sum()),
        "median_gap_cut": float(np.median(classed.gap_cut)) if len(classed) else math.nan,
        "params_within": int(rows.params_within.sum()),
        "params_scored": int(rows.params_scored.sum()),
        "cpu_s_median": float(rows.cpu_s.median()),
        "target": TARGET,
        "rows": rows.to_dict(orient="records"),
    }


def bench_blind(
    seeds: tuple[int, ...] = (1,),
    jobs: int = 2,
    fast: bool = False,
    only: tuple[str, ...] = (),
    which: int = 1,
):
    """Every form of blind set `which` (those in `only` when given) once per seed, in `jobs` processes."""
    todo = [(n, s, fast, which) for s in seeds for n in _module(which).BLIND_FORMS if not only or n in only]
    return summarize(pd.DataFrame(run_all(_run, todo, jobs)), which)


def _run(args: tuple[str, int, bool, int]) -> dict:
    """Picklable wrapper of run_blind."""
    return run_blind(*args)


def main(argv: list[str] | None = None) -> int:
    """Run the blind set and print the score (or its JSON)."""
    p = argparse.ArgumentParser(prog="python -m seagen.discrepancy.blindbench")
    p.add_argument("--set", type=int, default=1, choices=sorted(MODULES), dest="which")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--fast", action="store_true", help="quick moves (the bench's FAST_MOVES)")
    p.add_argument("--only", nargs="*", default=[])
    p.add_argument("--json", action="store_true")
    a = p.parse_args(argv)
    s = bench_blind((a.seed,), a.jobs, a.fast, tuple(a.only), a.which)
    if a.json:
        print(json.dumps(s, indent=2, default=float))
        return 0
    for r in s["rows"]:
        ok = "right" if r["right"] else ("WRONG CLAIM" if r["wrong_claim"] else "missed")
        print(
            f"{r['form']:20s} {r['expected_class']:20s} -> {r['discovered']:20s} {r['term']:18s} "
            f"{'claimed' if r['claimed'] else 'unclaimed':9s} {ok:11s} params {r['params_within']}/"
            f"{r['params_scored']} gap cut {r['gap_cut']:.0%} cpu {r['cpu_s']:.0f} s"
        )
    print(
        f"right and claimed {s['right_claimed']:.0%} of {s['cases']} (classed forms "
        f"{s['right_claimed_classed']:.0%}); wrong claims {s['wrong_claims']}; median gap cut "
        f"{s['median_gap_cut']:.0%}; parameters within {WITHIN:g} sigma: "
        f"{s['params_within']}/{s['params_scored']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
