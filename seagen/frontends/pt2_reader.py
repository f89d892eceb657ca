"""A checked .pt2 -> ExportedProgram without torch.export.load: the program from its JSON through torch's
own deserializer, the weights and constants as tensors made from their raw bytes."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from seagen.errors import UserError
from seagen.frontends.archives import Pt2, check_pt2


def read_pt2(p: Path) -> Any:
    """The ExportedProgram of a .pt2 that passed `check_pt2` (refused before anything is read otherwise)."""
    import torch
    from torch._export.serde import schema
    from torch._export.serde.serialize import ExportedProgramDeserializer, _dict_to_dataclass

    arc = check_pt2(p)
    root = _root(p)
    try:
        program = _dict_to_dataclass(schema.ExportedProgram, arc.program)
        state = _tensors(arc, arc.weights, f"{root}/data/weights/", torch)
        consts = _tensors(arc, arc.constants, f"{root}/data/constants/", torch)
        inputs = arc.sample_inputs if arc.sample_inputs else None
        return ExportedProgramDeserializer().deserialize(program, state, consts, inputs)
    except UserError:
        raise
    except Exception as e:  # the deserializer raises many types for programs it cannot rebuild
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(f"{p}: not a readable .pt2 program: {msg}") from None


def _root(p: Path) -> str:
    """The archive's root folder."""
    from seagen.filekind import split_root, zip_members

    return split_root(zip_members(p))[0]


def _tensors(arc: Pt2, cfg: dict[str, Any], folder: str, torch: Any) -> dict[str, Any]:
    """{fqn: tensor} for a weights or constants config: raw bytes viewed with the recorded dtype, size,
    stride and offset (several entries may share one file), or the weights-only pickle already read."""
    from torch._export.serde import schema
    from torch._export.serde.serialize import (
        _dict_to_dataclass,
        deserialize_scalar_type,
        deserialize_size,
        deserialize_storage_offset,
        deserialize_stride,
    )

    out: dict[str, Any] = {}
    flat: dict[str, Any] = {}
    for fqn, raw_meta in cfg["config"].items():
        member = folder + raw_meta["path_name"]
        if raw_meta.get("use_pickle"):
            out[fqn] = arc.tensors[member]
            continue
        meta = _dict_to_dataclass(schema.TensorMeta, raw_meta["tensor_meta"])
        dtype = deserialize_scalar_type(meta.dtype)
        if member not in flat:
            data = arc.raw(member)
            if len(data) % torch.empty((), dtype=dtype).element_size():
                raise UserError(f"{member}: {len(data)} bytes is not a whole number of {dtype} values")
            flat[member] = torch.frombuffer(bytearray(data), dtype=dtype) if data else torch.empty(0)
        base = flat[member]
        if base.dtype != dtype:
            raise UserError(f"{member}: entries of dtypes {base.dtype} and {dtype} share one file")
        size = deserialize_size(meta.sizes)
        if not base.numel():
            t = torch.zeros(size, dtype=dtype)
        else:
            t = torch.as_strided(
                base, size, deserialize_stride(meta.strides), deserialize_storage_offset(meta.storage_offset)
            )
        out[fqn] = torch.nn.Parameter(t, requires_grad=meta.requires_grad) if raw_meta.get("is_param") else t
    return out
