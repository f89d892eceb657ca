"""`seagen export`: the command line of the exporter (thin: parse, call, print)."""

from __future__ import annotations

import argparse
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
        help="model file (.pt, TorchScript, .pt2 or .onnx), or default:NAME (see seagen models)",
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
        "in as the predictor) and the controller runtime (sea_pid, sea_control)",
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
    """Export (checked against the original), optionally check on data, then write; 1 if a check fails."""
    from seagen.errors import CheckFailed
    from seagen.export import check_out_dir, prepare, write
    from seagen.runtime.control import proven_actuator

    check_out_dir(args.out)
    ex = prepare(
        args.model,
        args.prefix,
        args.weights,
        args.calib,
        args.features,
        args.onnx,
        args.allow_pickle,
        controller=args.controller,
        target=args.target,
        actuator=proven_actuator(args.actuator),
        package=args.package,
    )
    if args.check:
        from seagen.datacheck import check_data_dir

        rep = check_data_dir(ex, args.check)
        print(rep.report())
        if not rep.ok:
            raise CheckFailed(f"{args.model}: the checks on {args.check} disagree; nothing written")
    written = write(ex, args.out)
    print(f"seagen export: {args.model} -> {Path(args.out)}/ ({', '.join(p.name for p in written)})")
    for line in [*ex.lines, ex.oracle.line()]:
        print("  " + line)
    return 0
