"""The `seagen` command: parses, calls one function per sub-command, prints; bad input exits 2."""

from __future__ import annotations

import argparse
import importlib
import sys

from seagen import __version__
from seagen.errors import CheckFailed, UserError
from seagen.workers import Terminated, stop_on_sigterm

# Each module defines register(subparsers); its handlers take the parsed args and return an exit code.
COMMAND_MODULES = (
    "seagen.cli.data",
    "seagen.cli.fit",
    "seagen.cli.export",
    "seagen.cli.control",
    "seagen.cli.discrepancy",
    "seagen.cli.verify",
    "seagen.cli.bench",
    "seagen.cli.pil",
    "seagen.cli.models",
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
    """Entry point; returns the exit code (2 for bad input, 1 for a failed check, 130 / 143 when stopped by
    SIGINT / SIGTERM, each with one line)."""
    with stop_on_sigterm():
        return _run(argv)


def _run(argv: list[str] | None) -> int:
    """Parse and dispatch; every error and stop becomes one line on stderr and an exit code."""
    try:
        args = build_parser().parse_args(argv)
        return int(args.func(args) or 0)
    except UserError as e:
        print(f"seagen: error: {e}", file=sys.stderr)
        return 2
    except CheckFailed as e:
        print(f"seagen: check failed: {e}", file=sys.stderr)
        return 1
    except OSError as e:  # a path the user gave cannot be read or written (a folder for a file, /proc, ...)
        where = e.filename if e.filename is not None else ""
        print(f"seagen: error: {where}: {e.strerror or e}", file=sys.stderr)
        return 2
    except Terminated:
        print("seagen: stopped (SIGTERM)", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("seagen: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
