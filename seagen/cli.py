"""The `seagen` command: parses, calls one function per sub-command, prints; bad input exits 2."""

from __future__ import annotations

import argparse
import importlib
import sys

from seagen import __version__
from seagen.errors import UserError

# Each module defines register(subparsers); its handlers take the parsed args and return an exit code.
COMMAND_MODULES = (
    "seagen.data.commands",
    "seagen.fit.commands",
    "seagen.codegen.commands",
    "seagen.build.commands",
    "seagen.control.commands",
    "seagen.discrepancy.commands",
    "seagen.demo",
)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser with every sub-command registered."""
    parser = argparse.ArgumentParser(
        prog="seagen",
        description="Integer-only C for data-driven SEA calibration and control models, proven bit-for-bit.",
    )
    parser.add_argument("--version", action="version", version=f"seagen {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (2 for bad input, with a message naming the problem)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except UserError as e:
        print(f"seagen: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("seagen: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
