"""`seagen demo`: the main job on the simulated actuator, end to end; and the regeneration of generated/."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from seagen.export import Export

from seagen.defaults import DEFAULT_PREFIX
from seagen.errors import UserError


def export_defaults(models: dict[str, Path], out: Path, calib: str | None = None) -> dict[str, Export]:
    """Export every default model (with its ONNX graph) into `out`; returns prefix -> Export."""
    from seagen.export import prepare, write

    done = {}
    for name, path in models.items():
        ex = prepare(str(path), prefix=DEFAULT_PREFIX[name], with_onnx=True, calib=calib)
        write(ex, out)
        done[ex.prefix] = ex
    return done


def regenerate(out: Path) -> None:
    """Re-export generated/ from the default model files kept in generated/models/."""
    models = {n: out / "models" / f"{n}.pt" for n in DEFAULT_PREFIX}
    export_defaults(models, out)


def build_defaults(out: Path, seed: int = 0) -> None:
    """From scratch: data (seed), the four default models, their exports (what generated/ holds)."""
    import tempfile

    from seagen.data.protocol import generate
    from seagen.data.schema import save_csv
    from seagen.fit.train import train_defaults
    from seagen.plant import PlantConfig

    with tempfile.TemporaryDirectory() as tmp:
        for split, df in generate(PlantConfig(), seed=seed).items():
            save_csv(df, Path(tmp) / f"{split}.csv")
        models = train_defaults(tmp, out / "models", seed=seed)
    export_defaults(models, out)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `demo` command."""
    p = sub.add_parser(
        "demo",
        help="the whole pipeline on the simulated actuator (what `make demo` runs)",
        description="Data (paper protocol) -> the four default models -> C export checked bit for bit -> "
        "closed-loop force control (Table II) -> the discrepancy workflow on data with a hidden effect; "
        "outputs in --out. --regenerate/--rebuild maintain generated/.",
    )
    p.add_argument("--out", default="demo_out", help="working directory (default demo_out)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--actuator", metavar="FILE", help="actuator description TOML (default: the paper's actuator)"
    )
    p.add_argument("--regenerate", metavar="DIR", help="only re-export DIR (generated/) from DIR/models/*.pt")
    p.add_argument(
        "--rebuild", metavar="DIR", help="only rebuild DIR (generated/) from scratch: data, training"
    )
    p.set_defaults(func=cmd_demo)


def cmd_demo(args: argparse.Namespace) -> int:
    """Run the steps in order, printing each result."""
    if args.seed < 0:
        raise UserError(f"--seed must be >= 0, got {args.seed}")
    if args.regenerate:
        regenerate(Path(args.regenerate))
        return 0
    if args.rebuild:
        build_defaults(Path(args.rebuild), args.seed)
        return 0
    from seagen.demo.steps import run_demo
    from seagen.runtime.control import proven_actuator

    run_demo(Path(args.out), args.seed, proven_actuator(args.actuator))
    return 0
