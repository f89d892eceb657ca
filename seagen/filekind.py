"""What a model file is, read from its bytes and never from its name: an ONNX protobuf, a torch zip archive
(TorchScript, torch.save, or anything else: checked as a torch.export archive) or a pickle. Runs no code."""

from __future__ import annotations

import io
import pickletools
import zipfile
from pathlib import Path

ONNX, TORCHSCRIPT, TORCH_SAVE, EXPORT, PICKLE, UNKNOWN = (
    "onnx", "torchscript", "torch.save", "export", "pickle", "unknown"
)  # fmt: skip

# members of a torch.save zip besides data.pkl and data/<n> (relative to the archive's root folder)
SAVE_META = frozenset(
    {
        ".format_version",
        ".storage_alignment",
        "byteorder",
        "version",
        ".data/version",
        ".data/serialization_id",
    }
)


def zip_members(p: Path) -> list[str]:
    """Names inside a zip file ([] for anything else, a broken zip included)."""
    try:
        with zipfile.ZipFile(p) as z:
            return z.namelist()
    except (zipfile.BadZipFile, OSError, ValueError):
        return []


def split_root(names: list[str]) -> tuple[str, list[str]]:
    """The archive's root folder (torch writes every member under one) and the names below it; a member
    outside it keeps its whole name."""
    root = names[0].split("/", 1)[0] if names and "/" in names[0] else ""
    return root, [n[len(root) + 1 :] if root and n.startswith(root + "/") else n for n in names]


def zip_layout(names: list[str]) -> str:
    """TorchScript (code/ and constants.pkl), a torch.save zip (data.pkl, its storages and bookkeeping), or
    EXPORT: everything else, checked against the torch.export layout member by member."""
    _root, rel = split_root(names)
    if "constants.pkl" in rel or any(r.startswith("code/") for r in rel):
        return TORCHSCRIPT
    if "data.pkl" in rel and all(r == "data.pkl" or is_storage(r, "data/") or r in SAVE_META for r in rel):
        return TORCH_SAVE
    return EXPORT


def is_storage(rel: str, folder: str) -> bool:
    """A raw storage member such as data/0."""
    return rel.startswith(folder) and rel[len(folder) :].isdigit()


def file_kind(p: Path) -> str:
    """ONNX, TORCHSCRIPT, TORCH_SAVE, EXPORT (a .pt2 or any other zip), PICKLE or UNKNOWN, by content."""
    with open(p, "rb") as f:
        head = f.read(4)
    if head.startswith(b"PK"):
        names = zip_members(p)
        return zip_layout(names) if names else UNKNOWN
    if head[:1] == b"\x80" and head[1:2] in (b"\x02", b"\x03", b"\x04", b"\x05"):
        return PICKLE
    return ONNX if is_onnx(p) else UNKNOWN


def is_onnx(p: Path) -> bool:
    """An ONNX ModelProto: parses as one (protobuf parsing runs no code) with an IR version and a graph."""
    import onnx
    from google.protobuf.message import DecodeError

    m = onnx.ModelProto()
    try:
        m.ParseFromString(p.read_bytes())
    except (DecodeError, ValueError, RuntimeError):
        return False
    return m.ir_version > 0 and m.HasField("graph")


def pickle_globals(data: bytes) -> list[str]:
    """Every `module.name` the pickle(s) in `data` would import, in order, read with pickletools (nothing is
    unpickled); consecutive pickles (a legacy torch.save file) are read until one does not parse.

    Raises ValueError for a pickle whose imports cannot be read statically (the extension registry, or a
    STACK_GLOBAL whose names are not literal strings)."""
    out: list[str] = []
    stream = io.BytesIO(data)
    while stream.tell() < len(data):
        start = stream.tell()
        try:
            out += _globals_of_one(stream)
        except ValueError:
            if start == 0:
                raise
            break
    return out


def _globals_of_one(stream: io.BytesIO) -> list[str]:
    """The imports of the one pickle at the stream's position (the stream is left after its STOP)."""
    out: list[str] = []
    strings: list[str | None] = []  # the recent pushes, a string or None for anything else
    memo: dict[int, str | None] = {}
    try:
        for op, arg, _pos in pickletools.genops(stream):
            name = op.name
            if name in ("GLOBAL", "INST"):
                out.append(_python3_name(*str(arg).split(" ", 1)))
            elif name == "STACK_GLOBAL":
                module, attr = strings[-2:] if len(strings) == 2 else (None, None)
                if module is None or attr is None:
                    raise ValueError("a STACK_GLOBAL whose names are not literal strings")
                out.append(_python3_name(module, attr))
            elif name.startswith("EXT"):
                raise ValueError("an import through the copyreg extension registry")
            if name in ("SHORT_BINUNICODE", "BINUNICODE", "BINUNICODE8", "UNICODE"):
                strings.append(str(arg))
            elif name in ("BINPUT", "LONG_BINPUT", "PUT"):
                memo[int(str(arg))] = strings[-1] if strings else None
            elif name == "MEMOIZE":
                memo[len(memo)] = strings[-1] if strings else None
            elif name in ("BINGET", "LONG_BINGET", "GET"):
                strings.append(memo.get(int(str(arg))))
            elif name not in ("FRAME", "PROTO", "MARK"):
                strings.append(None)
            del strings[:-2]
    except ValueError:
        raise
    except Exception as e:  # genops raises several types on bytes that are not a pickle
        raise ValueError(f"not a readable pickle: {e}") from None
    return out


def _python3_name(module: str, name: str) -> str:
    """`module.name` as Python 3 resolves a protocol-2 pickle's import (`__builtin__` -> `builtins`)."""
    import _compat_pickle

    module, name = _compat_pickle.NAME_MAPPING.get((module, name), (module, name))
    return f"{_compat_pickle.IMPORT_MAPPING.get(module, module)}.{name}"
