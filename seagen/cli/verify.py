"""`seagen verify`: the equivalence gate for committed C (thin: parse, call, print)."""

from __future__ import annotations

import argparse
from pathlib import Path

from seagen.atomic import atomic_path, writable_place
from seagen.toolchain.targets import NAMES


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `verify` command."""
    p = sub.add_parser(
        "verify",
        help="check committed C against its model bit for bit (for firmware CI)",
        description="Build the C in DIR as it is on disk (never re-rendered) and check it against MODEL: "
        "first drift (hand-edited files, another model, another seagen version, by file name), then bit for "
        "bit against the integer references (numpy, torch, onnxruntime) rebuilt from DIR's NAME.seagen.json, "
        "and within the proven bound against the model itself. Exit 0: everything agrees; 1: a "
        "disagreement (the first failing input and both outputs are printed); 2: bad input.",
    )
    p.add_argument(
        "dir", metavar="DIR", help="folder holding the export (NAME.c, NAME.h, NAME.seagen.json, ...)"
    )
    p.add_argument(
        "--model",
        required=True,
        help="the model file the C was exported from, or default:NAME (see seagen models)",
    )
    p.add_argument("--prefix", metavar="NAME", help="which export of DIR (default: the one made from MODEL)")
    p.add_argument(
        "--data", metavar="DIR", help="data folder: also check its test/validation rows and trials"
    )
    p.add_argument("--vectors", type=int, default=10_000, metavar="N", help="random vectors (default 10000)")
    p.add_argument(
        "--target",
        "--core",
        dest="core",
        choices=NAMES,
        default="host",
        help="where the C runs: host (cffi) or an emulated core (arm-none-eabi-gcc + unicorn); --core is the "
        "same option",
    )
    p.add_argument("--features", metavar="SPEC", help="feature specification, as given to seagen export")
    p.add_argument(
        "--actuator",
        metavar="FILE",
        help="actuator description, as given to seagen export (a model file's own is used; a FILE that "
        "disagrees with it is refused)",
    )
    p.add_argument(
        "--allow-pickle",
        action="store_true",
        help="unpickle a .pt holding arbitrary Python objects (RUNS CODE from the file: trusted files only)",
    )
    p.add_argument(
        "--misra",
        action="store_true",
        help="also check the folder's C with cppcheck 2.10's MISRA C:2012 addon (findings outside seagen's "
        "deviation record fail; suppressions in the files are refused; skipped without cppcheck 2.10)",
    )
    p.add_argument(
        "--prove",
        action="store_true",
        help="also prove the folder's C free of run-time errors over its contracts' domain with Frama-C Eva "
        "(one check per public function; any alarm fails; docs/prove.md; exit 2 without frama-c)",
    )
    p.add_argument(
        "--junit",
        metavar="FILE",
        help="also write a JUnit XML report (one test case per check; bad input: one errored case)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.set_defaults(func=cmd_verify)


def cmd_verify(args: argparse.Namespace) -> int:
    """Run every check, print the report, write the JUnit file; 0 agrees, 1 disagrees. Bad input (exit 2)
    still prints the JSON object and writes the JUnit file, each carrying the error."""
    from seagen.errors import UserError
    from seagen.runtime.control import proven_actuator
    from seagen.verify.result import Verdict
    from seagen.verify.run import verify

    if args.junit and (why := "a folder" if Path(args.junit).is_dir() else writable_place(args.junit)):
        raise UserError(f"{args.junit}: cannot write the JUnit report there ({why})")
    try:
        verdict = verify(
            args.dir,
            args.model,
            args.prefix,
            args.data,
            args.vectors,
            args.core,
            args.features,
            args.allow_pickle,
            misra=args.misra,
            actuator=proven_actuator(args.actuator),
            prove=args.prove,
        )
    except UserError as e:
        failed = Verdict(args.prefix or "?", args.dir, error=str(e))
        report(args, failed, text=False)
        raise
    report(args, verdict)
    return 0 if verdict.ok else 1


def report(args: argparse.Namespace, verdict, text: bool = True) -> None:
    """Print the verdict (JSON with --json, else text when `text`) and write --junit atomically."""
    if args.json or text:
        print(verdict.to_json() if args.json else verdict.text())
    if args.junit:
        with atomic_path(Path(args.junit)) as tmp:
            Path(tmp).write_bytes(verdict.junit())
