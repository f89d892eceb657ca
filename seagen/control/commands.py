"""`seagen simulate`: the paper's force-control experiment in closed loop, per configuration."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from seagen.errors import UserError


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `simulate` command."""
    from seagen.control.experiment import CONFIGS

    p = sub.add_parser("simulate", help="closed-loop force control on the simulated SEA (paper Table II)")
    p.add_argument("--json", action="store_true", help="print one JSON object keyed by configuration")
    p.add_argument("--plots", metavar="DIR", help="write a step-response plot per configuration")
    p.add_argument("--config", action="append", choices=sorted(CONFIGS), help="configurations (default all)")
    p.add_argument("--latency", type=float, default=0.1, help="cloud round-trip latency, s (default 0.1)")
    p.add_argument("--impl", choices=("c", "py"), default="c", help="controller: C via cffi or Python twin")
    p.add_argument("--seed", type=int, default=0, help="plant noise seed (default 0)")
    p.set_defaults(func=cmd_simulate)


def cmd_simulate(args: argparse.Namespace) -> int:
    """Run each configuration at 5, 10, 15 N over the contact angles; print the table or JSON."""
    from seagen.control.experiment import CONFIGS, run_config

    if args.latency < 0:
        raise UserError(f"--latency must be >= 0 s, got {args.latency}")
    names = args.config or list(CONFIGS)
    results = {n: run_config(n, args.latency, args.impl, args.seed) for n in names}
    if args.plots:
        from seagen.control.plots import step_plot

        for n, res in results.items():
            step_plot(n, res, Path(args.plots) / f"step_{n}.png")
    table = {
        n: {t: {k: v for k, v in r.items() if k != "trace"} for t, r in res.items()}
        for n, res in results.items()
    }
    if args.json:
        print(json.dumps(table, indent=2))
        return 0
    print(f"{'config':<14}{'target N':>9}{'error N':>9}{'settling s':>12}{'to final s':>12}{'settled':>9}")
    for n, res in table.items():
        for t, r in res.items():
            s = "-" if r["settling_s"] is None else f"{r['settling_s']:.3f}"
            print(
                f"{n:<14}{t:>9}{r['error_avg_n']:>9.3f}{s:>12}{r['settling_final_s']:>12.3f}{r['settled']:>9}"
            )
    return 0
