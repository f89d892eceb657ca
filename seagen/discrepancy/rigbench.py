"""`seagen discrepancy bench --rig`: rig-style logs (jittered clocks, both conventions, other units) through
`data import`, then the workflow: nothing hidden, single effects, mis-set base parameters."""

from __future__ import annotations

import io
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from seagen.actuator import Actuator, default_actuator
from seagen.data.logimport import import_log, load_map
from seagen.discrepancy.bench import FAST_MOVES, HIDEABLE, case_moves, chosen, draw, run_all
from seagen.discrepancy.families import misset_case
from seagen.discrepancy.replay import runs_from_frames
from seagen.discrepancy.riglog import CONVENTIONS, rig_csv, rig_map, rig_trials
from seagen.discrepancy.workflow import identify
from seagen.plant import PlantConfig

# Loop periods (integer ms, drawn per sample) of the clocks tried: 200, 250, 500 Hz jittered; 1 kHz steady.
CLOCKS = {200: (4, 5, 6), 250: (3, 4, 5), 500: (1, 2, 3), 1000: (1,)}
RECOVERED = 0.05  # a mis-set parameter counts as recovered within 5 % of the truth


def alt_map(act: Actuator | None = None) -> str:
    """A second dialect's map (for `act`, the paper's when None): seconds, volts, lbf, other column names."""
    return (
        rig_map(act)
        .replace('column = "millis"\nunit = "ms"', 'column = "time_s"\nunit = "s"')
        .replace('column = "pwm_pct"\nunit = "%"', 'column = "u_V"\nunit = "V"')
        .replace('column = "shaft_kgf"\nunit = "kgf"', 'column = "F_shaft_lbf"\nunit = "lbf"')
    )


def _dialect(text: str, act: Actuator) -> str:
    """The rig CSV in the second dialect (s, V of the supply of `act`, lbf, other names)."""
    df = pd.read_csv(io.StringIO(text))
    df["millis"] = df["millis"] / 1000.0
    df["pwm_pct"] = df["pwm_pct"] * (act.motor.supply_v / 100.0)
    df["shaft_kgf"] = df["shaft_kgf"] * 9.80665 / 4.4482216152605
    df = df.rename(columns={"millis": "time_s", "pwm_pct": "u_V", "shaft_kgf": "F_shaft_lbf"})
    return df.to_csv(index=False, float_format="%.9g")


def plan(seeds: int) -> list[tuple]:
    """Per seed: nothing hidden on every clock x convention (two dialects), two single effects, two mis-set
    bases."""
    out: list[tuple] = []
    for s in range(seeds):
        for i, (hz, conv) in enumerate((h, c) for h in CLOCKS for c in CONVENTIONS):
            out.append(("control", (), 1000 * s + i, hz, conv, i % 2))
        rng = np.random.default_rng(20_000 + s)
        for k, e in enumerate(rng.choice(HIDEABLE, size=2, replace=False)):
            out.append(("single", (str(e),), 1000 * s + 100 + k, 250, CONVENTIONS[k % 2], 0))
        for k in range(2):  # two mis-set bases (one or two of friction, compliance, pot-drop gain, linkage)
            out.append(("misset", (), 1000 * s + 200 + k, 250, CONVENTIONS[(s + k) % 2], 1 - k))
    return out


def run_case(
    kind: str,
    effects: tuple[str, ...],
    seed: int,
    hz: int,
    conv: str,
    dialect: int,
    act: Actuator | None = None,
) -> dict:
    """One case on actuator `act` (the paper's when None): simulate the rig, write its log, import it with
    its map and that actuator, run the workflow."""
    act = act or default_actuator()
    rng = np.random.default_rng(seed)
    truth = base = PlantConfig(actuator=act)
    hidden = {e: draw(e, rng, act) for e in effects}
    for e, p in hidden.items():
        truth, base = truth.with_effect(e, True, **p), base.with_effect(e, False)
    wrong: dict[str, tuple[float, float]] = {}
    if kind == "misset":
        truth, base, wrong = misset_case(seed, act)
    # a mis-set base on the protocol's moves: quick moves do not pin the pot-drop gain (docs/discrepancy.md)
    moves = case_moves(act=act) if kind == "misset" else case_moves(FAST_MOVES, act)
    frames = rig_trials(truth, moves, seed=seed, convention=conv, loop_ms=CLOCKS[hz])
    text = rig_csv(frames, act=act)
    with tempfile.TemporaryDirectory() as tmp:
        log, mp = Path(tmp) / "rig.csv", Path(tmp) / "map.toml"
        log.write_text(_dialect(text, act) if dialect else text)
        mp.write_text(alt_map(act) if dialect else rig_map(act))
        df = import_log(log, load_map(mp), act)
    t0 = time.perf_counter()
    res = identify(runs_from_frames([("rig", df)]), base)
    recal = {f"{n.name}.{p}": v for n in res.recalibrated for p, v in n.params.items()}
    added = [n.name for n in res.effects]
    err = {k: abs(recal.get(k, b) / t - 1) for k, (b, t) in wrong.items()}
    return {
        "kind": kind,
        "clock_hz": hz,
        "convention": conv,
        "dialect": dialect,
        "hidden": "+".join(effects) or "-",
        "seed": seed,
        "verdict": res.verdict,
        "lag": res.timing.lag if res.timing else float("nan"),
        "lag_ok": res.timing is not None and abs(res.timing.lag - (0.0 if conv == "from_row" else 1.0)) < 0.1,
        "named": "+".join(added) or "-",
        "recalibrated": "+".join(n.name for n in res.recalibrated) or "-",
        "first_correct": bool(effects) and bool(added) and added[0] in effects,
        "untouched": res.verdict == "none" and not added and not res.recalibrated,
        "recovered": bool(wrong) and not added and all(v <= RECOVERED for v in err.values()),
        "misset": "+".join(f"{k} {b:.4g} for {t:.4g}" for k, (b, t) in wrong.items()) or "-",
        "misset_error": max(err.values()) if err else float("nan"),
        "unpinned": "+".join(res.check.unpinned) if res.check else "",
        "rms_before": res.rms_before,
        "rms_after": res.rms_after,
        "noise_floor": res.noise_floor,
        "seconds": time.perf_counter() - t0,
    }


def _run(args: tuple) -> dict:
    """Picklable wrapper of run_case."""
    return run_case(*args)


def summarize(rows: pd.DataFrame) -> dict:
    """The rig benchmark's goal numbers."""
    ctl, single, mis = (rows[rows.kind == k] for k in ("control", "single", "misset"))
    return {
        "control_untouched_rate": float(ctl.untouched.mean()) if len(ctl) else float("nan"),
        "lag_found_rate": float(rows.lag_ok.mean()),
        "single_first_correct_rate": float(single.first_correct.mean()) if len(single) else float("nan"),
        "misset_recovered_rate": float(mis.recovered.mean()) if len(mis) else float("nan"),
        "seconds_per_dataset": float(rows.seconds.median()),
        "cases": rows.to_dict(orient="records"),
    }


def bench_rig(
    seeds: int,
    jobs: int = 2,
    kinds: tuple[str, ...] = ("control", "single", "misset"),
    act: Actuator | None = None,
    only: tuple[str, ...] = (),
) -> dict:
    """Run the planned rig cases (of `kinds`, those `chosen` by `only`) on actuator `act` (the paper's when
    None; in `jobs` processes), summarize."""
    todo = [(*c, act) for c in plan(seeds) if c[0] in kinds and chosen(c, only)]
    return {
        "actuator": (act or default_actuator()).name,
        **summarize(pd.DataFrame(run_all(_run, todo, jobs))),
    }
