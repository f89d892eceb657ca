"""`seagen discrepancy` (replay, locate, name, add, report) and `seagen discrepancy bench`."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from seagen.actuator import Actuator


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `discrepancy` command (and its `bench` action)."""
    p = sub.add_parser(
        "discrepancy",
        help="find where measured data and the simulated SEA disagree, name the missing effect, add it",
        description="seagen discrepancy --measured DIR_OR_CSV [--base plant.toml] --out REPORT_DIR [--json]"
        "  |  seagen discrepancy bench [--seeds N] [--families | --rig [--quick]] [--actuator FILE] [--json]",
    )
    p.add_argument("action", nargs="?", choices=["bench"], help="run the benchmark instead")
    p.add_argument("--measured", help="a CSV or a directory of CSVs (the data schema)")
    p.add_argument("--base", help="plant config TOML to start from (default: the shipped effect catalogue)")
    p.add_argument(
        "--actuator",
        metavar="FILE",
        help="actuator description TOML (default: the measured folder's actuator.toml, else the paper's; "
        "one that disagrees with the folder's is refused; never rewritten); bench: the design the cases "
        "simulate and the rig logs are imported with",
    )
    p.add_argument("--out", help="report directory (written whole, or not at all)")
    p.add_argument("--seeds", type=int, default=3, help="bench: seeds (cases per seed: 14; --families: 8)")
    p.add_argument(
        "--families",
        action="store_true",
        help="bench: the independent families (forms outside the catalogue, mis-set bases, control)",
    )
    p.add_argument(
        "--rig",
        action="store_true",
        help="bench: rig-style logs (200-1000 Hz jittered ms clocks, both command conventions, other units) "
        "through data import: nothing hidden, single effects, mis-set bases",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="bench --families: quick moves (about half the time); bench --rig: nothing-hidden cases only",
    )
    p.add_argument(
        "--jobs",
        type=int,
        help="processes: the batched replays of the search split over them (the same results with any "
        "number; default: the cores, at most 2); bench: worker processes (default 2)",
    )
    p.add_argument(
        "--cases",
        metavar="NAMES",
        help="bench: only these cases, comma-separated: a hidden effect (the cases hiding it), a kind "
        "(single, pair, control; --rig: misset) or, with --families, a family name",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_discrepancy)


def cmd_discrepancy(args: argparse.Namespace) -> int:
    """Run the workflow (or the bench) and print its result."""
    from seagen.errors import UserError

    if args.action == "bench":
        args.jobs = 2 if args.jobs is None else args.jobs
        return cmd_bench(args)
    if not args.measured or not args.out:
        raise UserError("discrepancy: --measured and --out are required (or use `discrepancy bench`)")
    from seagen.atomic import locked_folder
    from seagen.cli.data import given_actuator
    from seagen.data.schema import data_actuator
    from seagen.discrepancy.parallel import default_jobs, keep_freed_memory, replays
    from seagen.discrepancy.replay import load_measured, load_timing, runs_from_frames
    from seagen.discrepancy.report import discovered_lines, summary, unpinned_words, write_report
    from seagen.discrepancy.workflow import identify
    from seagen.plant import PlantConfig, load_config

    folder = Path(args.measured) if Path(args.measured).is_dir() else Path(args.measured).parent
    act = data_actuator(folder, given_actuator(args))
    base = load_config(args.base, act) if args.base else PlantConfig(actuator=act)
    timing = load_timing(args.measured)
    runs = runs_from_frames(load_measured(args.measured), timing)
    jobs = default_jobs() if args.jobs is None else max(1, args.jobs)
    keep_freed_memory()  # before the helpers start: they inherit it
    with replays(jobs):  # the lag the folder declares (timing.json) is pinned: Runs.declared
        res = identify(runs, base)
    with locked_folder(Path(args.out).resolve().parent):  # another report onto --out waits, then replaces
        write_report(res, args.out, str(args.measured))
    s = summary(res)
    if args.json:
        print(json.dumps(s, indent=2))
    else:
        named = (
            ", ".join(
                f"{e['name']} ({e['confidence']:.0%}{'' if e['claimed'] else ', not claimed'})"
                for e in s["effects"]
            )
            or "nothing"
        )
        recal = ", ".join(
            f"{r['effect']}.{r['param']} {r['before']:.4g} -> {r['after']:.4g}" for r in s["recalibrated"]
        )
        print(f"verdict: {s['verdict']}; added: {named}; recalibrated: {recal or 'nothing'}")
        if s["named_first"]:
            print(f"named first: {s['named_first']} (closest single change: {s['closest_single'] or '-'})")
        for line in discovered_lines(res):  # the term library's form, when the catalogue ran out
            print(line)
        if unpinned_words(res):
            print(f"note: {unpinned_words(res)}")
        if res.timing is not None:
            print(res.timing.words())
            if res.timing.warning:
                print(f"warning: {res.timing.warning}")
            if res.timing.problem:
                print(f"timing problem: {res.timing.problem}")
        print(
            f"held-out residual RMS {s['rms_before']:.3g} -> {s['rms_after']:.3g} noise sigmas "
            f"(noise floor {s['noise_floor']:.3g}); report in {args.out}/report.md"
        )
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    """Run the benchmark and print its goal numbers."""
    from seagen.cli.data import given_actuator
    from seagen.data.protocol import sample_every
    from seagen.discrepancy.bench import bench
    from seagen.errors import UserError
    from seagen.plant import PlantConfig

    if args.seeds < 1:
        raise UserError(f"--seeds must be >= 1, got {args.seeds}")
    act = given_actuator(args)  # None: the paper's
    if act is not None:
        sample_every(PlantConfig(actuator=act))  # a loop rate the plant cannot log: refused first
    args.only = _cases(args)
    if args.families:
        return _print_families(args, act)
    if args.rig:
        return _print_rig(args, act)
    out = bench(args.seeds, jobs=max(1, args.jobs), act=act, only=args.only)
    return _print_bench(
        out,
        args.json,
        lambda row: (
            f"{row['kind']:8s} hidden={row['hidden']:40s} named={row['named']:40s} {row['verdict']:11s} "
            f"e/n={row['effect_to_noise']:7.2f} rms {row['rms_before']:7.2f} -> {row['rms_after']:5.2f} "
            f"({row['seconds']:.0f} s)"
        ),
    )


def _cases(args: argparse.Namespace) -> tuple[str, ...]:
    """The --cases names, checked against what the chosen benchmark can run (none: every case)."""
    from seagen.discrepancy.bench import HIDEABLE
    from seagen.discrepancy.families import FAMILIES
    from seagen.errors import UserError

    if args.cases is None:
        return ()
    names = tuple(n.strip() for n in args.cases.split(",") if n.strip())
    known = (
        (*FAMILIES, "misset", "control")
        if args.families
        else (*HIDEABLE, "single", "control", *(("misset",) if args.rig else ("pair",)))
    )
    bad = [n for n in names if n not in known]
    if bad or not names:
        raise UserError(
            f"--cases: unknown case name(s) {', '.join(bad) or '(none given)'}; known: {', '.join(known)}"
        )
    return names


def _print_bench(out: dict, as_json: bool, case_line, table=None) -> int:
    """A benchmark's result: one JSON object, or its goal numbers, an optional table, one line per case."""
    if as_json:
        print(json.dumps(out, indent=2, default=str))
        return 0
    for k, v in out.items():
        if k not in ("cases", "per_family"):
            print(f"{k}: {v:.3f}" if isinstance(v, float) else f"{k}: {v}")
    if table is not None:
        table()
    for row in out["cases"]:
        print(case_line(row))
    return 0


def _print_families(args: argparse.Namespace, act: Actuator | None) -> int:
    """Run the family benchmark and print its per-family table and goal numbers."""
    from seagen.discrepancy.famibench import bench_families

    out = bench_families(args.seeds, jobs=max(1, args.jobs), fast=args.quick, act=act, only=args.only)

    def per_family() -> None:
        print("family            cases first_ok spurious recovered gap_cut (physics) s/dataset")
        for r in out["per_family"]:
            print(
                f"{r['family']:17s} {r['cases']:5d} {r['first_ok']:8.2f} {r['spurious']:8.2f} "
                f"{r['recovered']:9.2f} {r['gap_cut']:7.2f} ({r['gap_cut_physics']:.2f}) {r['seconds']:9.0f}"
            )

    return _print_bench(
        out,
        args.json,
        lambda r: (
            f"{r['family']:17s} seed={r['seed']:4d} expected={r['expected']:20s} first={r['first']:20s} "
            f"added={r['added']:30s} recal={r['recalibrated']:30s} gap_cut={r['gap_cut']:.2f} "
            f"({r['seconds']:.0f} s)"
        ),
        per_family,
    )


def _print_rig(args: argparse.Namespace, act: Actuator | None) -> int:
    """Run the rig benchmark and print its goal numbers and cases."""
    from seagen.discrepancy.rigbench import bench_rig

    kinds = ("control",) if args.quick else ("control", "single", "misset")
    out = bench_rig(args.seeds, jobs=max(1, args.jobs), kinds=kinds, act=act, only=args.only)
    return _print_bench(
        out,
        args.json,
        lambda r: (
            f"{r['kind']:8s} {r['clock_hz']:5d} Hz {r['convention']:10s} dialect={r['dialect']} "
            f"hidden={r['hidden']:20s} lag={r['lag']:.2f} {r['verdict']:11s} named={r['named']:25s} "
            f"recal={r['recalibrated']:25s} rms {r['rms_before']:6.2f} -> {r['rms_after']:5.2f} "
            f"({r['seconds']:.0f} s)"
            + (f" mis-set {r['misset']} (worst {r['misset_error']:.1%} off)" if r["kind"] == "misset" else "")
            + (f" not pinned: {r['unpinned']}" if r["unpinned"] else "")
        ),
    )
