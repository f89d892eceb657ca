"""`seagen export`: the command line of the exporter (thin: parse, call, print)."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `export` command."""
    p = sub.add_parser(
        "export",
        help="quantize a model and emit integer-only C (NAME.h, NAME.c + runtime)",
        description="Quantize MODEL to fixed point and write NAME.h/NAME.c rendered from templates, the C "
        "runtime it needs, and optionally the quantized ONNX graph. MODEL: a model.pt from `seagen train`, "
        "a torch.save'd nn.Sequential, a TorchScript module, or an .onnx (Linear/Gemm with ReLU, LeakyReLU, "
        "Hardtanh, Tanh, Sigmoid); bare networks need --features.",
    )
    p.add_argument("model", metavar="MODEL", help="model file (.pt, TorchScript or .onnx)")
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
        "--check",
        metavar="DIR",
        help="after writing, check C == numpy == torch == onnxruntime on "
        "DIR's test and validation sets and report max |C - float|",
    )
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    """Export, print the summary, optionally check equivalence."""
    from seagen.codegen.export import prepare, write

    ex = prepare(args.model, args.prefix, args.weights, args.calib, args.features, args.onnx, args.target)
    written = write(ex, args.out)
    print(f"seagen export: {args.model} -> {args.out}/ ({', '.join(p.name for p in written)})")
    for line in ex.lines:
        print("  " + line)
    if args.check:
        from seagen.build.equivalence import check_data_dir

        print(check_data_dir(ex, args.check).report())
    return 0
