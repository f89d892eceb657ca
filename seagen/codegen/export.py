"""`seagen export`: any supported model -> quantized IR -> NAME.h/NAME.c (+ runtime, + NAME.onnx)."""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from seagen.build.runtime import runtime_sources
from seagen.codegen.cfmt import assert_valid_prefix
from seagen.codegen.render import RUNTIME, render
from seagen.codegen.summary import summary_lines
from seagen.codegen.targets import RUNTIME as TARGET_RUNTIME
from seagen.codegen.targets import check_target
from seagen.errors import UserError
from seagen.ir import FloatMLP, FloatModel, QModel
from seagen.quant.load import load_float_model
from seagen.quant.mlp import quantize_mlp
from seagen.quant.sf import quantize_sf


@dataclass
class Export:
    """What an export produced: the float and quantized models, the files, and the summary."""

    float_model: FloatModel
    qmodel: QModel
    prefix: str
    files: dict[str, str]
    onnx_bytes: bytes | None = None
    lines: list[str] = field(default_factory=list)


def calib_ranges(data_dir: str, names: list[str]) -> list[list[float]]:
    """Observed [min, max] of each named feature on the training split of a data directory."""
    from seagen.data.features import derive
    from seagen.data.schema import load_split

    df = derive(load_split(data_dir, "train"))
    missing = [n for n in names if n not in df.columns]
    if missing:
        raise UserError(f"{data_dir}: cannot compute a calibration range for {', '.join(missing)}")
    return [[float(df[n].min()), float(df[n].max())] for n in names]


def quantize(model: FloatModel, weight_bits: int = 16) -> QModel:
    """Float IR -> quantized IR (MLP or surface fit)."""
    if weight_bits not in (8, 16):
        raise UserError(f"--weights must be int16 or int8, not int{weight_bits}")
    if isinstance(model, FloatMLP):
        return quantize_mlp(model, weight_bits)
    return quantize_sf(model)


def default_prefix(model_path: str) -> str:
    """A C identifier from the model file name (e.g. mlp_calibration.pt -> mlp_calibration)."""
    stem = re.sub(r"[^A-Za-z0-9_]", "_", Path(model_path).stem)
    return stem if stem[:1].isalpha() else f"m_{stem}"


def prepare(
    model_path: str,
    prefix: str | None = None,
    weights: str = "int16",
    calib: str | None = None,
    features: str | None = None,
    with_onnx: bool = False,
    target: str = "portable",
) -> Export:
    """Everything of an export, in memory (nothing is written)."""
    prefix = assert_valid_prefix(prefix or default_prefix(model_path))
    bits = {"int16": 16, "int8": 8}.get(weights)
    if bits is None:
        raise UserError(f"--weights must be int16 or int8, not {weights!r}")
    fm = load_float_model(model_path, features, (lambda names: calib_ranges(calib, names)) if calib else None)
    qm = quantize(fm, bits)
    # issue 12 hook: the target's kernel and the extra runtime header it includes (seagen/codegen/targets.py)
    files = {**render(qm, prefix, target), **runtime_sources(*RUNTIME, *TARGET_RUNTIME[check_target(target)])}
    onnx_bytes = None
    if with_onnx:
        from seagen.reference.onnx_ref import build_onnx

        onnx_bytes = build_onnx(qm, prefix).SerializeToString()
    return Export(fm, qm, prefix, files, onnx_bytes, summary_lines(qm))


def write(ex: Export, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write all files atomically: staged in a temporary folder inside out_dir, then renamed in."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(dir=out, prefix=".export."))
    try:
        names = dict(ex.files)
        for name, text in names.items():
            (stage / name).write_text(text)
        if ex.onnx_bytes is not None:
            (stage / f"{ex.prefix}.onnx").write_bytes(ex.onnx_bytes)
        written = []
        for f in sorted(stage.iterdir()):
            os.replace(f, out / f.name)
            written.append(out / f.name)
        return written
    finally:
        shutil.rmtree(stage, ignore_errors=True)
