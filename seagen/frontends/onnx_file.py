"""An ONNX file as seagen opens it: the protobuf alone, then its external data, each data file checked first
(inside the model's folder, there, holding every tensor's bytes); each problem one line naming the file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from seagen.errors import UserError


def load_onnx(path: Path) -> Any:
    """The ONNX model; external data must lie inside the model's folder, be there and hold the values."""
    import onnx
    from onnx import external_data_helper as ext

    try:
        model = onnx.load(str(path), load_external_data=False)
    except Exception as e:  # onnx raises several types for unreadable files
        raise UserError(f"{path}: not a readable ONNX file: {e}") from None
    folder = path.resolve().parent
    external = [t for t in ext._get_all_tensors(model) if ext.uses_external_data(t)]
    locs = [{e.key: e.value for e in t.external_data}.get("location", "") for t in external]
    for t, loc in zip(external, locs, strict=True):
        _check_external(path, folder, t.name, loc)
    try:
        ext.load_external_data_for_model(model, str(folder))
        for t, loc in zip(external, locs, strict=True):
            _values(t, loc)
    except Exception as e:  # onnx and numpy raise several types
        lines = str(e).strip().splitlines() or [type(e).__name__]
        raise UserError(f"{path}: cannot read external data: {lines[0]}") from None
    return model


def _values(t: Any, loc: str) -> None:
    """A tensor read from external data holds as many bytes as its shape and type need."""
    from onnx import numpy_helper

    try:
        numpy_helper.to_array(t)
    except ValueError as e:
        raise ValueError(f"tensor '{t.name}': '{loc}' holds too few bytes (cut short?): {e}") from None


def _check_external(path: Path, folder: Path, tensor: str, loc: str) -> None:
    """A tensor's external data file: named, inside the model's folder, and there."""
    if not loc:
        raise UserError(f"{path}: tensor '{tensor}' has external data but names no file (no 'location')")
    target = (folder / loc).resolve()
    if not target.is_relative_to(folder):
        raise UserError(f"{path}: tensor '{tensor}' has external data '{loc}' outside the model folder")
    if not target.exists():
        raise UserError(
            f"{path}: tensor '{tensor}' has its data in '{loc}', which is missing (looked for {target}; "
            "copy it next to the model)"
        )
    if not target.is_file():
        raise UserError(f"{path}: tensor '{tensor}' has its data in '{loc}', which is not a file")


def widened_to_float32(model: Any) -> Any:
    """A copy of a float16/bfloat16 graph computing in float32: its low-precision initializers, constants,
    Cast targets and declared types widened (what its own rounding is measured against)."""
    import onnx
    from onnx import TensorProto, numpy_helper

    low = (TensorProto.FLOAT16, TensorProto.BFLOAT16)
    wide = onnx.ModelProto()
    wide.CopyFrom(model)
    g = wide.graph

    def widen(t: Any) -> None:
        if t.data_type in low:
            t.CopyFrom(numpy_helper.from_array(numpy_helper.to_array(t).astype("float32"), t.name))

    for t in g.initializer:
        widen(t)
    for n in g.node:
        for a in n.attribute:
            if a.name == "to" and n.op_type == "Cast" and a.i in low:
                a.i = TensorProto.FLOAT
            if a.type == onnx.AttributeProto.TENSOR:
                widen(a.t)
    for v in [*g.input, *g.output, *g.value_info]:
        if v.type.tensor_type.elem_type in low:
            v.type.tensor_type.elem_type = TensorProto.FLOAT
    return wide


def inlined(model: Any, path: Path) -> Any:
    """The graph with its local functions (onnxscript's @script functions, exporters' modules) expanded by
    onnx's own inliner, for reading; the model itself when it has none (the oracle runs the file as is)."""
    if not model.functions:
        return model
    from onnx import inliner

    try:
        return inliner.inline_local_functions(model)
    except Exception as e:  # onnx raises several types for functions it cannot expand
        lines = str(e).strip().splitlines() or [type(e).__name__]
        raise UserError(f"{path}: cannot inline its local functions: {lines[0]}") from None
