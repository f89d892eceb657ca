"""`seagen train` and `seagen evaluate`."""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

from seagen.atomic import writable_place
from seagen.cli.data import add_actuator, given_actuator
from seagen.defaults import model_arg
from seagen.errors import UserError

TRAIN_EPILOG = """\
examples:
  seagen train --data data --model sf --loss mae --task calibration --out sf_calibration.pt
  seagen train --data data --model mlp --loss mse --task control --hidden 8,16 --out mlp_control.pt
  seagen train --data data --model mlp --loss any --trials 40 --storage sqlite:///sweep.db \\
      --study-name cal --out best.pt      # run the same line on several machines to share one sweep
"""


def parse_hidden(text: str | None) -> tuple[int, ...] | None:
    """'16,32' -> (16, 32); errors name --hidden."""
    if text is None:
        return None
    try:
        sizes = tuple(int(t) for t in re.split(r",|(?<=\d)-", text) if t.strip())
    except ValueError:
        raise UserError(f"--hidden {text!r}: expected layer sizes like 16,32") from None
    if not sizes or any(s < 1 for s in sizes):
        raise UserError(f"--hidden {text!r}: expected positive layer sizes like 16,32")
    return sizes


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `train` and `evaluate` commands."""
    t = sub.add_parser(
        "train",
        help="fit an SF or MLP calibration/control model and write the model file",
        description="Fit one model on DIR/train.csv, score it on test.csv and validation.csv, write the "
        "model file atomically (module or polynomial, feature spec, units, observed ranges, loss, seed, "
        "metrics).",
        epilog=TRAIN_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    t.add_argument("--data", required=True, metavar="DIR", help="data directory (seagen data generate)")
    t.add_argument("--model", required=True, choices=("sf", "mlp"), help="surface fit or MLP")
    t.add_argument(
        "--loss", default="mse", choices=("mse", "mae", "any"), help="loss (default mse; any: searched)"
    )
    t.add_argument(
        "--task",
        default="calibration",
        choices=("calibration", "control"),
        help="calibration: sensors -> force (N); control: desired force + sensors -> compression (mm)",
    )
    t.add_argument("--hidden", help="MLP hidden sizes, e.g. 16,32 (default 16,32 calibration, 8,16 control)")
    t.add_argument("--trials", type=int, default=0, help="Optuna trials over structure/loss/lr (MLP only)")
    t.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    t.add_argument("--storage", help="Optuna storage URL shared by several machines, e.g. sqlite:///x.db")
    t.add_argument("--study-name", help="Optuna study name (default seagen-TASK-mlp-seedN)")
    t.add_argument("--activation", choices=("relu", "leaky_relu", "tanh"), help="MLP activation (relu)")
    t.add_argument("--out", required=True, metavar="FILE", help="model file to write, e.g. model.pt")
    add_actuator(
        t,
        "actuator description TOML: must match DIR/actuator.toml (the data's, which the model file "
        "records; without the file the paper's)",
    )
    t.set_defaults(func=cmd_train)
    e = sub.add_parser(
        "evaluate",
        help="Table IV / V errors of model files beside the kinematics baseline",
        description="Score model files on DIR/test.csv and DIR/validation.csv the paper's way (rows with "
        "force > 5 N; maximum = worst contact angle's mean), with the naive kinematics beside them.",
    )
    e.add_argument(
        "models",
        nargs="+",
        metavar="MODEL",
        type=model_arg,
        help="model files written by seagen train, or default:NAME (see seagen models)",
    )
    e.add_argument("--data", required=True, metavar="DIR", help="data directory with test.csv (+ validation)")
    e.add_argument("--json", action="store_true", help="print one JSON object keyed by model name")
    e.add_argument("--plots", metavar="DIR", help="write PNGs: SF surfaces and validation predictions")
    e.add_argument(
        "--allow-pickle",
        action="store_true",
        help="unpickle arbitrary objects (RUNS CODE: trusted files only)",
    )
    e.set_defaults(func=cmd_evaluate)


def cmd_train(args: argparse.Namespace) -> int:
    """Train one model and print its scores."""
    from seagen.fit.train import metrics_summary, train

    if args.trials and args.model != "mlp":
        raise UserError("--trials: the search is for --model mlp (an SF has no hyper-parameters)")
    if args.seed < 0:
        raise UserError(f"--seed must be >= 0, got {args.seed}")
    if Path(args.out).is_dir():
        raise UserError(f"{args.out}: is a folder; --out names the model file to write")
    if why := writable_place(args.out):
        raise UserError(f"{args.out}: {why}")
    obj = train(
        args.data,
        model=args.model,
        loss=args.loss,
        task=args.task,
        hidden=parse_hidden(args.hidden),
        trials=args.trials,
        seed=args.seed,
        out=args.out,
        storage=args.storage,
        study_name=args.study_name,
        activation=args.activation,
        actuator=given_actuator(args),
    )
    shape = f" {'-'.join(map(str, obj['hidden']))}" if obj.get("hidden") else ""
    took = f"{obj['train_seconds']:.1f} s"
    print(f"wrote {args.out}: {obj['kind']}{shape} {obj['task']} ({obj['loss']}) in {took}")
    print(metrics_summary(obj))
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Print Table IV / V (or JSON) and optionally write the plots."""
    from seagen.actuator import is_default
    from seagen.data.schema import data_actuator
    from seagen.fit.evaluate import evaluate, format_tables, frames_and_models, model_names
    from seagen.fit.kinematics import error_threshold_n

    result = evaluate(args.models, args.data, args.allow_pickle)
    act = data_actuator(args.data)  # read once: the threshold, the paper's rows and the plots' geometry
    print(
        json.dumps(result, indent=2)
        if args.json
        else format_tables(result, is_default(act), error_threshold_n(act)),
        end="" if not args.json else "\n",
    )
    if args.plots:
        from seagen.fit.plots import write_plots
        from seagen.geometry import geometry

        frames, models = frames_and_models(args.models, args.data, args.allow_pickle)
        named = dict(zip(model_names(args.models), models, strict=True))
        written = write_plots(named, frames, args.plots, geometry(act))
        if not args.json:
            print("wrote " + ", ".join(str(p) for p in written))
    return 0
