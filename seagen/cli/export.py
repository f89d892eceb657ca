"""`seagen export`: the command line of the exporter (thin: parse, call, print)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from seagen.defaults import model_arg


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `export` command."""
    p = sub.add_parser(
        "export",
        help="quantize a model and emit integer-only C (NAME.h, NAME.c + runtime)",
        description="Quantize MODEL to fixed point and write NAME.h/NAME.c rendered from templates and the C "
        "runtime it needs (optionally the quantized ONNX graph). MODEL: a model.pt from `seagen train`, an "
        "nn.Sequential saved whole, a TorchScript archive, a torch.export .pt2, or an .onnx; it must compute "
        "a chain of dense layers each followed by at most one ReLU, LeakyReLU, PReLU, Hardtanh, ReLU6, Clip, "
        "Tanh, Sigmoid, ELU, SELU, Softplus, GELU, Mish, SiLU, HardSigmoid or HardSwish. Bare networks need "
        "--features. Every export is checked against the original model run "
        "by its own runtime. Exit codes: 0 written, 1 a check disagreed (nothing written), 2 bad input.",
    )
    p.add_argument(
        "model",
        metavar="MODEL",
        type=model_arg,
        nargs="+",
        help="model file (.pt, TorchScript, .pt2 or .onnx), or default:NAME (see seagen models); several "
        "models go into one package in one run (each NAME from its file name; every one is checked before "
        "any is written)",
    )
    p.add_argument("--out", default=".", help="output directory (default: current)")
    p.add_argument("--prefix", help="C symbol prefix NAME (default: from the file name)")
    p.add_argument(
        "--weights", choices=("int16", "int8"), default="int16", help="weight width (default int16)"
    )
    p.add_argument("--calib", metavar="DIR", help="data directory whose train.csv gives the input ranges")
    p.add_argument(
        "--features", metavar="SPEC", help="feature specification (JSON or TOML) for bare networks"
    )
    p.add_argument(
        "--target",
        choices=("portable", "cortex-m0plus", "cortex-m4"),
        default="portable",
        help="kernel of NAME_infer: portable C99 (default, the reference), cortex-m4 (SMLAD; M4/M7/M33, "
        "portable fallback elsewhere) or cortex-m0plus (ARMv6-M); same integers on every target",
    )
    p.add_argument("--onnx", action="store_true", help="also write the quantized integer graph NAME.onnx")
    p.add_argument(
        "--controller",
        action="store_true",
        help="control models: also write NAME_controller.h/.c (tuned PID, limits, margin, the model wired "
        "in as the predictor) and the controller runtime (sea_pid, sea_control); with several models, for "
        "each control model among them",
    )
    p.add_argument(
        "--allow-pickle",
        action="store_true",
        help="unpickle a .pt that holds arbitrary Python objects (this RUNS CODE from the file: only for "
        "files you trust)",
    )
    p.add_argument(
        "--actuator",
        metavar="FILE",
        help="actuator description (TOML) for a bare network or ONNX graph; a seagen model file carries its "
        "own, and a FILE that disagrees with it is refused (default: the model's, else the paper's)",
    )
    p.add_argument(
        "--package",
        metavar="NAME",
        help="CMake library of the folder: its CMakeLists.txt builds every export there as seagen::NAME "
        "(default: models; every export in one folder shares it)",
    )
    p.add_argument(
        "--check",
        metavar="DIR",
        help="before writing, also check C == numpy == torch == onnxruntime on DIR's test and validation "
        "sets, and the C against the original model on those rows",
    )
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    """Export each model (checked against its original), optionally check on data, then write them all;
    1 if a check fails (nothing written), 2 on bad input (nothing written)."""
    from seagen.errors import CheckFailed, UserError
    from seagen.export import Export, check_out_dir, prepare, write
    from seagen.runtime.control import proven_actuator

    check_out_dir(args.out)
    models: list[str] = args.model
    if len(models) > 1 and args.prefix:
        raise UserError("--prefix names one export; with several models each NAME comes from its file name")
    several = len(models) > 1
    exports: list[Export] = []
    for model in models:
        ex = prepare(
            model,
            args.prefix,
            args.weights,
            args.calib,
            args.features,
            args.onnx,
            args.allow_pickle,
            controller=None if several and args.controller else args.controller,
            target=args.target,
            actuator=proven_actuator(args.actuator),
            package=args.package,
        )
        clash = [m for m, e in zip(models, exports, strict=False) if e.prefix == ex.prefix]
        if clash:
            raise UserError(
                f"{model}: its C name {ex.prefix} is also {clash[0]}'s; export them one by one with --prefix"
            )
        if args.check:
            from seagen.datacheck import check_data_dir

            rep = check_data_dir(ex, args.check)
            print(rep.report())
            if not rep.ok:
                raise CheckFailed(f"{model}: the checks on {args.check} disagree; nothing written")
        exports.append(ex)
    for model, ex in zip(models, exports, strict=True):
        written = write(ex, args.out)
        names = ", ".join(os.path.relpath(p, args.out) for p in written)
        print(f"seagen export: {model} -> {Path(args.out)}/ ({names})")
        for line in [*ex.lines, ex.oracle.line()]:
            print("  " + line)
    return 0
