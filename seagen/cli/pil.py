"""`seagen pil`: the export's firmware on an emulated board in closed loop with the plant (thin)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from seagen.atomic import atomic_path, writable_place


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `pil` command."""
    p = sub.add_parser(
        "pil",
        help="processor in the loop: the export's firmware on an emulated board (QEMU) against the plant",
        description="Build the controller export in DIR (made with seagen export --controller) into firmware "
        "for the board of --core (Cortex-M4: QEMU mps2-an386; Cortex-M0+ build: QEMU microbit), boot it in "
        "qemu-system-arm and close the paper's force loop (targets 1/4, 1/2, 3/4 of the actuator's force "
        "range at --actuators contact angles) with the Python plant over the board's UART, one frame per "
        "tick. Every tick's command and controller state (and, with --cal-model, the force estimate) is "
        "compared bit for bit with the Python twins; the firmware reports its own instruction count per "
        "tick (SysTick under -icount). Exit 0: every tick agrees; 1: a disagreement (the first tick is "
        "printed); 2: bad input, or QEMU missing, crashed or silent.",
    )
    p.add_argument("dir", metavar="DIR", help="folder holding the export (NAME.c, NAME_controller.c, ...)")
    p.add_argument("--model", required=True, help="the control model file the export was made from")
    p.add_argument("--core", required=True, choices=("cortex-m4", "cortex-m0plus"), help="the emulated core")
    p.add_argument("--prefix", metavar="NAME", help="which export of DIR (default: the one made from MODEL)")
    p.add_argument(
        "--cal-model", metavar="FILE", help="a calibration model exported into DIR: its NAME_step runs too"
    )
    p.add_argument(
        "--ticks",
        type=int,
        metavar="N",
        help="ticks per run (default: the experiment's 6 s at the actuator's control.loop_hz, 600 at 100 Hz)",
    )
    p.add_argument("--actuators", type=int, default=10, metavar="K", help="contact angles (default 10)")
    p.add_argument(
        "--allow-pickle", action="store_true", help="unpickle a .pt (RUNS CODE: trusted files only)"
    )
    p.add_argument("--junit", metavar="FILE", help="also write a JUnit XML report (one test case per check)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.add_argument(
        "--actuator",
        metavar="FILE",
        help="actuator description, as given to seagen export (the model file's own is used; a FILE that "
        "disagrees with it is refused)",
    )
    p.set_defaults(func=cmd_pil)


def cmd_pil(args: argparse.Namespace) -> int:
    """Run the experiment on the board; print the report and instruction counts; 0 agrees, 1 disagrees."""
    from seagen.errors import UserError
    from seagen.runtime.control import proven_actuator
    from seagen.verify.pil import run_pil

    if args.junit and (why := "a folder" if Path(args.junit).is_dir() else writable_place(args.junit)):
        raise UserError(f"{args.junit}: cannot write the JUnit report there ({why})")
    res = run_pil(
        args.dir,
        args.model,
        args.core,
        args.ticks,
        args.actuators,
        args.cal_model,
        args.prefix,
        args.allow_pickle,
        proven_actuator(args.actuator),
    )
    v, s = res.verdict, res.summary()
    if args.json:
        print(json.dumps({**json.loads(v.to_json()), "instructions": s}, indent=2))
    else:
        print(
            f"  firmware on {s['board']} ({s['core']}): {s['instr_mean']:,.0f} instructions per tick "
            f"(max {s['instr_max']:,}), {s['instr_per_actuator']:,.0f} per actuator"
        )
        print(v.text())
    if args.junit:
        with atomic_path(Path(args.junit)) as tmp:
            Path(tmp).write_bytes(v.junit())
    return 0 if v.ok else 1
