"""`seagen bench`: the command line of the Cortex-M benchmark (thin: parse, call, print)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `bench` command."""
    p = sub.add_parser(
        "bench",
        help="instructions, cycles, flash, RAM, stack and linked helpers of an export on emulated Cortex-M",
        description="For every model in DIR (a `seagen export` folder) and core: executed instructions and a "
        "cycle estimate of NAME_infer, NAME_step and the controller tick (control predictors), flash, RAM, "
        "stack, library helpers linked, and an ISA check. Exits 1 if a float helper is linked or an "
        "executed instruction does not exist on the core. Needs arm-none-eabi-gcc and seagen[mcu] (unicorn).",
    )
    p.add_argument("dir", metavar="DIR", help="export folder")
    p.add_argument(
        "--target",
        action="append",
        choices=("cortex-m0plus", "cortex-m4"),
        help="core to measure on (repeatable; default both)",
    )
    p.add_argument(
        "--flash-wait",
        type=int,
        default=0,
        metavar="N",
        help="flash wait states priced into the cycles (default 0: zero-wait memory; "
        "1: e.g. a SAMD21 M0+ at 48 MHz)",
    )
    p.add_argument(
        "--actuator",
        metavar="FILE",
        help="the actuator description DIR was exported for (its sha256 must be the one DIR's sea_act_<id>.h "
        "records; default: the paper's): the controller tick's settings and the run's counts and ticks",
    )
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.set_defaults(func=cmd_bench)


def cmd_bench(args: argparse.Namespace) -> int:
    """Measure, print, exit 1 on a float helper or an ISA violation."""
    from seagen.bench.run import as_json, bench_dir, failures, table
    from seagen.runtime.control import proven_actuator

    cpus = tuple(args.target or ("cortex-m4", "cortex-m0plus"))
    rows = bench_dir(Path(args.dir), cpus, args.flash_wait, proven_actuator(args.actuator))
    print(json.dumps(as_json(rows), indent=2) if args.json else table(rows))
    bad = failures(rows)
    for line in bad:
        print(f"seagen bench: {line}", file=sys.stderr)
    return 1 if bad else 0
