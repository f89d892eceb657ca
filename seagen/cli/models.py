"""`seagen models`: the shipped default models, their files and exports (usable as `default:NAME`)."""

from __future__ import annotations

import argparse
import json


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `models` command."""
    p = sub.add_parser(
        "models",
        help="list the shipped default models and their paths (use them as default:NAME)",
        description="The default models shipped with seagen (trained on the simulated actuator): the "
        "argument that names each (default:NAME, accepted wherever a model file is), its file, and the "
        "export of it shipped beside (prefix and folder).",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object keyed by default:NAME")
    p.set_defaults(func=cmd_models)


def cmd_models(args: argparse.Namespace) -> int:
    """Print one line per shipped model (or JSON)."""
    from seagen.defaults import DEFAULT_PREFIX, SCHEME, generated_dir, shipped

    rows = {
        SCHEME + name: {"file": str(path), "export": DEFAULT_PREFIX[name], "export_dir": str(generated_dir())}
        for name, path in shipped().items()
    }
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    width = max(map(len, rows))
    for arg, row in rows.items():
        print(f"{arg:<{width}}  {row['file']}  (export {row['export']} in {row['export_dir']})")
    return 0
