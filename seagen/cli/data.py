"""`seagen data generate`, `seagen data import` and `seagen data summary`."""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from seagen.atomic import writable_place
from seagen.errors import UserError

if TYPE_CHECKING:
    from seagen.actuator import Actuator

ACTUATOR_HELP = "actuator description TOML (default: the paper's, seagen/actuators/paper.toml)"


def add_actuator(p: argparse.ArgumentParser, help: str = ACTUATOR_HELP) -> None:
    """The --actuator FILE option."""
    p.add_argument("--actuator", metavar="FILE", help=help)


def given_actuator(args: argparse.Namespace) -> Actuator | None:
    """The description --actuator names, proven (runtime.control.proven_actuator), able to push to its
    force range in the calibration protocol's time (data.reach) and to read a force finely enough to hold
    it within the settling band (control.tune.hold_problem), or None."""
    from seagen.actuator import ActuatorError
    from seagen.control.tune import hold_problem
    from seagen.data.reach import reach_problem
    from seagen.runtime.control import proven_actuator

    act = proven_actuator(getattr(args, "actuator", None))
    if act is not None and (problem := reach_problem(act) or hold_problem(act)):
        raise ActuatorError(f"{act.source} ('{act.name}'): {problem}")
    return act


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `data` command group."""
    p = sub.add_parser("data", help="generate or summarize calibration data sets")
    dsub = p.add_subparsers(dest="data_command", metavar="ACTION", required=True)
    g = dsub.add_parser(
        "generate", help="collect train/test/validation CSVs on the simulated SEA (paper protocol)"
    )
    g.add_argument("--out", required=True, help="output directory (created)")
    g.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    g.add_argument(
        "--config",
        help="plant config TOML: what is non-ideal, one [effects.NAME] table per effect changed (enabled, "
        "its parameters; every key: docs/plant.md) (default: the shipped catalogue)",
    )
    add_actuator(g, ACTUATOR_HELP + "; kept as OUT/actuator.toml")
    g.set_defaults(func=cmd_generate)
    i = dsub.add_parser(
        "import",
        help="a rig's log -> train/test/validation CSVs at the actuator's control-loop rate (train, "
        "evaluate, export) and as logged in OUT/logged (discrepancy); a column map TOML with units",
    )
    i.add_argument("log", help="the rig's log (CSV with a header row)")
    i.add_argument("--map", required=True, help="column map TOML: log columns and units -> seagen's schema")
    i.add_argument(
        "--out",
        required=True,
        help="output directory (created; every file written whole, logged rows in logged/)",
    )
    add_actuator(
        i,
        "the rig's actuator description TOML (ranges, units, loop rate; default: the paper's); "
        "kept as OUT/actuator.toml",
    )
    i.set_defaults(func=cmd_import)
    s = dsub.add_parser("summary", help="rows per split, naive kinematics error, friction by angle")
    s.add_argument("dir", help="data directory holding train.csv, test.csv, validation.csv")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_summary)


def cmd_generate(args: argparse.Namespace) -> int:
    """Generate the three splits and write them atomically."""
    from tqdm import tqdm

    from seagen.actuator import default_actuator, to_toml
    from seagen.data.logimport import TIMING_FILE, own_timing, timing_text
    from seagen.data.protocol import generate, sample_every
    from seagen.plant import PlantConfig, load_config

    act = given_actuator(args) or default_actuator()
    cfg = load_config(args.config, act) if args.config else PlantConfig(actuator=act)
    sample_every(cfg)  # a loop rate the plant cannot log: refused first, naming the description's file
    out = Path(args.out)
    if args.seed < 0:
        raise UserError(f"--seed must be >= 0, got {args.seed}")
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: is a file; --out names a folder")
    if why := writable_place(out):
        raise UserError(f"{out}: {why}")
    with tqdm(total=3, desc="simulating", unit="split") as bar:

        def step(split: str) -> None:  # called as each split starts: the count is of the splits done
            bar.update(0 if split == "train" else 1)
            bar.set_description_str(f"simulating {split}")

        splits = generate(cfg, seed=args.seed, progress=step)
        bar.set_description_str("simulated")
        bar.update(1)
    _check_generated(splits, act, out)
    info = {
        ACTUATOR_FILE: to_toml(act, "the actuator these data were simulated on"),
        TIMING_FILE: timing_text(own_timing()),  # the replay pins seagen's own convention
    }
    _write_splits(out, splits, info)
    return 0


ACTUATOR_FILE = "actuator.toml"  # seagen.data.schema.ACTUATOR_FILE (cli imports data lazily)


def _check_generated(splits: dict, act: Actuator, out: Path) -> None:
    """Simulated splits that do not cover the actuator's force range: refused (exit 2), nothing written."""
    from seagen.actuator import default_actuator
    from seagen.data.coverage import REACH, check_coverage
    from seagen.plant.config import Motor

    mine, paper = Motor.of(act).v_max_mm_s, Motor.of(default_actuator()).v_max_mm_s
    check_coverage(
        splits,
        act,
        str(out),
        f"the calibration protocol does not load the spring that far on this design (its nut moves "
        f"{mine:.3g} mm/s at no load, the paper's {paper:.3g} mm/s): a faster drive or a lower "
        "control.force_max_n",
        held_out=REACH,
    )


def _write_splits(out: Path, splits: dict, extra: dict[str, str] | None = None, what: str = "") -> None:
    """Write every split (and the `extra` {file name: text}) into a staging folder inside `out`, then
    rename each into place under a lock on `out` (two commands writing one folder at once leave the
    files of one of them)."""
    from seagen.atomic import locked_folder
    from seagen.data.schema import save_csv

    out.mkdir(parents=True, exist_ok=True)
    staged = tempfile.mkdtemp(dir=out, prefix=".staged.")
    try:
        for name, df in splits.items():
            save_csv(df, Path(staged) / f"{name}.csv")
        for name, text in (extra or {}).items():
            (Path(staged) / name).write_text(text)
        with locked_folder(out):
            for name in [f"{k}.csv" for k in splits] + list(extra or {}):
                os.replace(Path(staged) / name, out / name)
    finally:
        for f in Path(staged).glob("*"):
            f.unlink()
        os.rmdir(staged)
    print(
        f"wrote {out}/: "
        + ", ".join(f"{k}.csv ({len(v)} rows)" for k, v in splits.items())
        + f" {what}".rstrip()
    )


def cmd_import(args: argparse.Namespace) -> int:
    """Convert a rig's log with a column map; nothing is written unless every row converts."""
    from seagen.actuator import default_actuator, to_toml
    from seagen.data.coverage import check_coverage
    from seagen.data.logimport import (
        LOGGED,
        TIMING_FILE,
        import_log,
        load_map,
        resample,
        split_trials,
        timing,
        timing_text,
    )

    act = given_actuator(args) or default_actuator()
    mapping = load_map(args.map)
    df = import_log(args.log, mapping, act)
    logged = split_trials(df)
    grid = {k: resample(v, act.loop_hz) for k, v in logged.items()}
    out = Path(args.out)
    check_coverage(
        grid,
        act,
        args.log,
        "the log's trials do not load the spring that far: log trials that do, or lower control.force_max_n "
        "in the description (--actuator)",
    )
    info = {
        TIMING_FILE: timing_text(timing(df, mapping)),
        ACTUATOR_FILE: to_toml(act, "the actuator this log was recorded on"),
    }
    _write_splits(out / LOGGED, logged, info, what="as logged (discrepancy)")
    _write_splits(out, grid, info, what=f"at {act.loop_hz:g} Hz (train, evaluate, export)")
    return 0


def cmd_summary(args: argparse.Namespace) -> int:
    """Print the summary of a data directory."""
    from seagen.fit.data_summary import format_summary, paper_data, summarize

    s = summarize(args.dir)
    print(json.dumps(s, indent=2) if args.json else format_summary(s, paper_data(args.dir)))
    return 0
