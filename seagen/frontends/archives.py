"""Archives by allow-list: every member of a .pt2 or TorchScript zip is one seagen knows and has checked, or
the file is refused, naming the member, before torch opens it. Nothing here unpickles beyond weights-only."""

from __future__ import annotations

import ast
import io
import json
import re
import struct
import zipfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from seagen.errors import UserError
from seagen.filekind import is_storage, pickle_globals, split_root

OPT_IN = "only --allow-pickle opens it (with torch, which can run code the file carries)"
META = frozenset({"byteorder", "version", ".data/version", ".data/serialization_id"})
TS_PICKLES = frozenset({"data.pkl", "constants.pkl", "traced_inputs.pkl"})
TS_STORAGES = ("data/", "constants/", "traced_inputs/")  # raw storage bytes, e.g. data/0
# torch's own helpers a TorchScript pickle names (its C++ unpickler implements them; none imports code).
# torch.device: a module attribute holding a device (LightningModule.to_torchscript() keeps one); the C++
# unpickler rebuilds it as c10::Device from the one string argument ("cpu", "cuda:0"; any other string is an
# error), plain data that runs no user code.
TS_PICKLE_HELPERS = frozenset(
    ["torch._utils._rebuild_tensor_v2", "collections.OrderedDict", "torch.device"]
    + [f"torch.jit._pickle.{n}" for n in ("restore_type_tag", "build_tensor_from_id", "build_genericlist")]
    + [f"torch.jit._pickle.build_{t}list" for t in ("int", "double", "bool", "tensor")]
)
STORAGE = re.compile(r"torch\.(Float|Double|Half|BFloat16|Long|Int|Short|Char|Byte|Bool)Storage")
TARGET = re.compile(r"torch\.ops\.\w+\.\w+(\.\w+)?|_operator\.\w+|math\.\w+|torch\._?sym_\w+")
# what a shape expression of a torch.export program may hold: torch hands it to sympy.sympify, which
# evaluates it as Python; it is written by sympy's srepr, e.g. "Add(Integer(1), Symbol('s0', integer=True))"
SYM_FUNCS = frozenset(
    """Symbol Integer Rational Float Add Mul Pow Mod Max Min Abs floor ceiling Eq Ne Lt Le Gt Ge Equality
    Unequality StrictLessThan LessThan StrictGreaterThan GreaterThan And Or Not Piecewise ExprCondPair
    BooleanTrue BooleanFalse true false NegativeOne One Zero Half Infinity NegativeInfinity oo zoo nan NaN
    ComplexInfinity IntInfinity NegativeIntInfinity int_oo FloorDiv ModularIndexing Where PythonMod CleanDiv
    CeilToInt FloorToInt CeilDiv LShift RShift PowByNatural FloatPow FloatTrueDiv IntTrueDiv ToFloat Identity
    IsNonOverlappingAndDenseIndicator TruncToFloat TruncToInt RoundToInt RoundDecimal""".split()  # noqa: SIM905
)
SYM_KEYWORDS = frozenset(
    """positive negative nonnegative nonpositive integer real rational finite infinite zero nonzero even odd
    commutative precision evaluate""".split()  # noqa: SIM905
)
SYM_NODES = (
    ast.Expression, ast.Call, ast.Name, ast.Load, ast.Constant, ast.keyword, ast.BinOp, ast.UnaryOp,
    ast.Compare, ast.BoolOp, ast.Add, ast.Sub, ast.Mult, ast.Div, ast.FloorDiv, ast.Mod, ast.Pow, ast.USub,
    ast.UAdd, ast.Not, ast.And, ast.Or, ast.Eq, ast.NotEq, ast.Lt, ast.LtE, ast.Gt, ast.GtE,
)  # fmt: skip
SYMBOL = re.compile(r"[A-Za-z]\w{0,30}")


def refuse(p: Path, member: str, why: str) -> UserError:
    """The one-line refusal naming the member."""
    return UserError(f"{p}: member {member}: {why}; {OPT_IN}")


def layout_problem(data: bytes) -> str | None:
    """Why a zip's directory is ambiguous, or None: the central directory must end exactly where the
    (zip64) end record starts, with nothing before the first member. Otherwise readers may disagree on which
    directory is the archive's (Python's zipfile assumes prepended data; torch's reader takes the offset as
    written), and torch would open members seagen never checked."""
    end = data.rfind(b"PK\x05\x06")
    if end < 0 or len(data) - end < 22:
        return "no end-of-directory record"
    size_cd, off_cd = struct.unpack("<II", data[end + 12 : end + 20])
    stop = end
    loc = end - 20
    if loc >= 0 and data[loc : loc + 4] == b"PK\x06\x07":  # zip64: the locator names the zip64 end record
        (rec,) = struct.unpack("<Q", data[loc + 8 : loc + 16])
        if data[rec : rec + 4] != b"PK\x06\x06":
            return "a zip64 locator that points at no zip64 end record"
        size_cd, off_cd = struct.unpack("<QQ", data[rec + 40 : rec + 56])
        stop = rec
    if off_cd + size_cd != stop or data[:4] != b"PK\x03\x04":
        return "its central directory is not where its end record says (data before it or a second directory)"
    return None


def _members(p: Path) -> tuple[zipfile.ZipFile, str, dict[str, str]]:
    """The open zip, its root folder and {name below the root: full name}; an ambiguous directory, a member
    outside the root or named twice is refused."""
    try:
        if why := layout_problem(p.read_bytes()):
            raise UserError(f"{p}: not a zip archive seagen reads: {why}")
        z = zipfile.ZipFile(p)
    except (zipfile.BadZipFile, OSError) as e:
        raise UserError(f"{p}: not a readable zip archive: {e}") from None
    names = z.namelist()
    twice = [n for n, k in Counter(names).items() if k > 1]
    if twice:
        z.close()
        raise refuse(p, twice[0], "appears twice in the archive")
    root, rel = split_root(names)
    for full, r in zip(names, rel, strict=True):
        if r == full and root:
            z.close()
            raise refuse(p, full, f"lies outside the archive's folder {root}/")
    return z, root, dict(zip(rel, names, strict=True))


def _read(z: zipfile.ZipFile, p: Path, full: str) -> bytes:
    """A member's bytes; an unreadable one is refused."""
    try:
        return z.read(full)
    except Exception as e:  # zipfile raises several types (bad CRC, encryption, compression)
        raise UserError(f"{p}: member {full}: cannot be read: {e}") from None


def _check_meta(p: Path, z: zipfile.ZipFile, rel: str, full: str) -> None:
    """Bookkeeping members: short ASCII text, little-endian byte order."""
    data = _read(z, p, full)
    if len(data) > 64 or not data.isascii():
        raise refuse(p, full, "is not the short text torch writes there")
    if rel == "byteorder" and data.strip() != b"little":
        raise refuse(p, full, f"byte order {data.decode().strip()!r} (seagen reads little-endian archives)")


# ---------------------------------------------------------------- TorchScript


def check_torchscript(p: Path) -> bytes:
    """A TorchScript archive: pickles that name only TorchScript classes (`__torch__.*`), torch storages and
    torch's own list/tensor rebuilders, raw storages, TorchScript source that defines no `__setstate__` (the
    one method torch.jit.load runs), bookkeeping and extra files; anything else is refused. Returns the
    checked members repacked into a fresh zip: torch reads exactly what was checked (a zip can hold two
    central directories, and torch's reader and Python's may pick different ones)."""
    z, _root, members = _members(p)
    buf = io.BytesIO()
    with z, zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as out:
        for rel, full in members.items():
            data = _read(z, p, full)
            if rel in TS_PICKLES or (rel.startswith("code/") and rel.endswith(".py.debug_pkl")):
                _check_ts_pickle(p, full, data)
            elif rel.startswith("code/") and rel.endswith(".py"):
                _check_ts_code(p, full, data)
            elif rel in META:
                _check_meta(p, z, rel, full)
            elif not (rel.startswith("extra/") or any(is_storage(rel, d) for d in TS_STORAGES)):
                raise refuse(p, full, "is not part of a TorchScript archive seagen reads")
            out.writestr(full, data)
        if "data.pkl" not in members:
            raise UserError(f"{p}: not a TorchScript archive seagen reads: it has no data.pkl")
    return buf.getvalue()


def _check_ts_pickle(p: Path, full: str, data: bytes) -> None:
    """Every import of a TorchScript pickle is a TorchScript class, a torch storage or a torch rebuilder."""
    try:
        names = pickle_globals(data)
    except ValueError as e:
        raise refuse(p, full, f"a pickle seagen cannot check ({e})") from None
    for g in names:
        if g.startswith("__torch__.torch.classes."):  # torchbind classes: their C++ __setstate__ runs on load
            raise refuse(
                p, full, f"a pickle that names {g}, a C++ class whose state-setting code runs on load"
            )
        if not (g.startswith("__torch__.") or STORAGE.fullmatch(g) or g in TS_PICKLE_HELPERS):
            raise refuse(p, full, f"a pickle that names {g}, not a TorchScript class or torch storage")


def _check_ts_code(p: Path, full: str, data: bytes) -> None:
    """TorchScript source: UTF-8 Python syntax without a `__setstate__` (run by torch.jit.load). Characters
    Python and TorchScript's lexer read differently (a lone carriage return ends a line for Python, not for
    TorchScript, so it can hide code from the syntax tree) are refused, and the name may not appear at all."""
    odd = next((c for c in (b"\r", b"\x0b", b"\x0c", b"\x00") if c in data), None)
    if odd is not None:
        raise refuse(p, full, f"holds the character {odd!r}, which Python and TorchScript read differently")
    if b"__setstate__" in data:
        raise refuse(p, full, "names __setstate__, code torch.jit.load would run on opening the file")
    try:
        ast.parse(data.decode("utf-8"))
    except (UnicodeDecodeError, SyntaxError, ValueError):
        raise refuse(p, full, "is not TorchScript source") from None


# ---------------------------------------------------------------- torch.export (.pt2)


@dataclass
class Pt2:
    """What seagen reads from a checked .pt2: the JSON program, its payload configs and sample inputs."""

    program: dict[str, Any]
    weights: dict[str, Any]  # {"config": {fqn: PayloadMeta as dict}}
    constants: dict[str, Any]
    sample_inputs: Any
    tensors: dict[str, Any] = field(default_factory=dict)  # full member name -> pickled tensor (use_pickle)
    raw: Callable[[str], bytes] = field(default=lambda _n: b"", repr=False)  # full member name -> bytes


def check_pt2(p: Path) -> Pt2:
    """A torch.export archive in the current layout: archive_format 'pt2', version 0, one models/NAME.json
    (node targets torch operators, shape expressions arithmetic), its weights and constants configs, the raw
    tensor bytes or tensor-only pickles they name, weights-only sample inputs, bookkeeping and extra files.
    Any other member (the older layout, AOTInductor, shared objects, unknown files) is refused by name."""
    z, root, members = _members(p)
    with z:
        programs = sorted(r for r in members if re.fullmatch(r"models/[^/]+\.json", r))
        name = programs[0][len("models/") : -len(".json")] if programs else "model"
        configs = (f"data/weights/{name}_weights_config.json", f"data/constants/{name}_constants_config.json")
        known = {"archive_format", "archive_version", f"models/{name}.json", *configs, *META}
        known.add(f"data/sample_inputs/{name}.pt")
        payload = {f"data/weights/{n}" for n in _paths(z, p, members, configs[0])}
        payload |= {f"data/constants/{n}" for n in _paths(z, p, members, configs[1])}
        for rel, full in members.items():
            if not (rel in known or rel in payload or rel.startswith("extra/")):
                raise refuse(p, full, "is not part of a torch.export archive seagen reads")
        for rel in ("archive_format", "archive_version", f"models/{name}.json"):
            if rel not in members:
                raise UserError(f"{p}: not a torch.export archive seagen reads: it has no {rel}")
        for rel, want in (("archive_format", b"pt2"), ("archive_version", b"0")):
            if _read(z, p, members[rel]).strip() != want:
                raise refuse(p, members[rel], f"is not {want.decode()!r} (seagen reads the current layout)")
        for rel in META & set(members):
            _check_meta(p, z, rel, members[rel])
        full = members[f"models/{name}.json"]
        program = _json(z, p, full)
        _check_program(p, full, program)
        cfgs = [_json(z, p, members[r]) if r in members else {"config": {}} for r in configs]
        tensors: dict[str, Any] = {}
        for cfg, folder in zip(cfgs, ("data/weights/", "data/constants/"), strict=True):
            for meta in cfg["config"].values():
                f = members.get(folder + meta["path_name"])
                if f is None:
                    raise UserError(f"{p}: not a complete .pt2: {folder}{meta['path_name']} is missing")
                if meta.get("use_pickle"):
                    tensors[f] = _weights_only(z, p, f, tensor=True)
        inputs = members.get(f"data/sample_inputs/{name}.pt")
        sample = _weights_only(z, p, inputs, tensor=False) if inputs else None
        data = {f: _read(z, p, f) for f in members.values() if f.startswith(f"{root}/data/")} if root else {}
    return Pt2(program, cfgs[0], cfgs[1], sample, tensors, lambda n: data[n])


def _json(z: zipfile.ZipFile, p: Path, full: str) -> Any:
    """A JSON member (a dict)."""
    try:
        doc = json.loads(_read(z, p, full).decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise refuse(p, full, f"is not JSON ({e})") from None
    if not isinstance(doc, dict):
        raise refuse(p, full, "is not a JSON object")
    return doc


def _paths(z: zipfile.ZipFile, p: Path, members: dict[str, str], rel: str) -> set[str]:
    """The payload file names (weight_N, tensor_N) a weights or constants config lists; a config entry of
    another kind (custom or opaque objects: pickles of arbitrary classes) is refused."""
    if rel not in members:
        return set()
    cfg = _json(z, p, members[rel])
    entries = cfg.get("config")
    if not isinstance(entries, dict):
        raise refuse(p, members[rel], "has no 'config' object")
    out = set()
    for key, meta in entries.items():
        path = meta.get("path_name") if isinstance(meta, dict) else None
        if not isinstance(path, str) or not re.fullmatch(r"(weight|tensor)_\d+", path):
            raise refuse(p, members[rel], f"entry {key!r} is a {path or 'non-tensor'} object, not a tensor")
        if not meta.get("use_pickle") and not isinstance(meta.get("tensor_meta"), dict):
            raise refuse(p, members[rel], f"entry {key!r} has no tensor_meta")
        out.add(path)
    return out


def _weights_only(z: zipfile.ZipFile, p: Path, full: str, tensor: bool) -> Any:
    """A member torch.load reads with weights_only=True; a tensor (or tuple/dict of them) is required."""
    import torch

    try:
        obj = torch.load(io.BytesIO(_read(z, p, full)), map_location="cpu", weights_only=True)
    except Exception:  # anything the weights-only unpickler rejects or cannot parse
        raise refuse(p, full, "a pickle that weights-only loading rejects") from None
    ok = isinstance(obj, torch.Tensor) if tensor else isinstance(obj, tuple | dict)
    if not ok:
        want = "a tensor" if tensor else "sample inputs"
        raise refuse(p, full, f"holds a {type(obj).__name__}, not {want}")
    return obj


def _check_program(p: Path, full: str, doc: dict[str, Any]) -> None:
    """Node targets are torch operators; shape expressions (parsed by sympy, which evaluates them) hold
    only numbers, operators, shape symbols and sympy's arithmetic functions."""
    for node in doc.get("graph_module", {}).get("graph", {}).get("nodes", []):
        target = node.get("target") if isinstance(node, dict) else None
        if not isinstance(target, str) or not TARGET.fullmatch(target):
            raise refuse(p, full, f"node target {target!r} is not a torch operator")
    for expr in _values(doc, "expr_str"):
        if not plain_sym_expr(expr):
            raise refuse(p, full, f"shape expression {str(expr)[:60]!r} is not plain arithmetic")


def plain_sym_expr(expr: Any) -> bool:
    """A shape expression built only of sympy's arithmetic (calls of the names above, numbers, symbol
    names as strings, assumption keywords, operators): nothing sympify's eval could turn into a call of
    anything else (no attribute, subscript, lambda or other name)."""
    if not isinstance(expr, str) or len(expr) > 2000 or "__" in expr:
        return False
    try:
        tree = ast.parse(expr, mode="eval")
    except (SyntaxError, ValueError):
        return False
    for n in ast.walk(tree):
        if not isinstance(n, SYM_NODES):
            return False
        if isinstance(n, ast.Call) and not (isinstance(n.func, ast.Name) and n.func.id in SYM_FUNCS):
            return False  # only sympy's names are called
        if isinstance(n, ast.Name) and n.id not in SYM_FUNCS and not SYMBOL.fullmatch(n.id):
            return False
        if isinstance(n, ast.keyword) and n.arg not in SYM_KEYWORDS:
            return False
        if isinstance(n, ast.Constant) and not (
            isinstance(n.value, bool | int | float)
            or (isinstance(n.value, str) and re.fullmatch(r"[\w.+\-]{1,64}", n.value))
        ):
            return False
    return True


def _values(doc: Any, key: str):
    """Every value stored under `key` anywhere in a JSON document."""
    stack = [doc]
    while stack:
        d = stack.pop()
        if isinstance(d, dict):
            if key in d:
                yield d[key]
            stack.extend(d.values())
        elif isinstance(d, list):
            stack.extend(d)


# The TorchScript ops a model's graph may hold (every node, dead ones included, checked after torch.jit.load
# and before anything runs: the ONNX conversion folds constants and the oracle runs forward): the layers
# seagen reads, pure tensor arithmetic, and the interpreter's own control flow and int/bool arithmetic.
# File I/O (aten::from_file, aten::save), printing, random ops and calls into Python are refused by name.
SCRIPT_ATEN = {
    "linear", "addmm", "mm", "matmul", "t", "permute", "transpose", "relu", "relu_", "leaky_relu",
    "leaky_relu_", "hardtanh", "hardtanh_", "clamp", "clamp_", "clamp_min", "clamp_max", "relu6", "tanh",
    "tanh_", "sigmoid", "sigmoid_", "batch_norm", "dropout", "dropout_", "feature_dropout", "alpha_dropout",
    "flatten", "view", "reshape", "contiguous", "to", "type_as", "add", "add_", "sub", "sub_", "mul", "mul_",
    "div", "div_", "rsub", "neg", "pow", "sqrt", "rsqrt", "reciprocal", "unsqueeze", "squeeze", "expand",
    "ones", "zeros", "full", "ones_like", "zeros_like", "full_like", "detach", "clone", "size", "dim", "len",
    "Int", "Float", "Bool", "ScalarImplicit", "item", "eq", "ne", "lt", "gt", "le", "ge", "__is__",
    "__isnot__", "__not__", "__and__", "__or__", "floordiv", "remainder", "format", "list", "slice",
    "select", "__getitem__", "append", "cat", "stack", "identity", "numel", "is_floating_point", "floor",
    "tensor",  # torch.tensor([...]) in forward: a tensor built from a list of numbers (pure, no I/O)
    # the smooth and piecewise-linear activations seagen reads (pure elementwise math)
    "elu", "elu_", "selu", "selu_", "softplus", "gelu", "mish", "silu", "silu_", "hardsigmoid",
    "hardsigmoid_", "hardswish", "hardswish_", "prelu",
}  # fmt: skip
SCRIPT_PRIM = {
    "Constant", "GetAttr", "ListConstruct", "ListUnpack", "TupleConstruct", "TupleUnpack", "TupleIndex",
    "NumToTensor", "device", "dtype", "If", "Loop", "RaiseException", "Uninitialized", "unchecked_cast",
    "isinstance", "min", "max", "shape", "layout", "requires_grad", "is_cuda", "data", "AutogradZero",
}  # fmt: skip


def _script_nodes(block: Any) -> Any:
    """Every node of a TorchScript graph or block, nested blocks included."""
    for n in block.nodes():
        yield n
        for b in n.blocks():
            yield from _script_nodes(b)


def check_script_ops(module: Any, p: Path) -> None:
    """Refuse a TorchScript module whose inlined graph holds an op outside SCRIPT_ATEN / SCRIPT_PRIM, naming
    it, before anything of the module runs."""
    try:
        graph = module.inlined_graph
    except Exception:  # a module without forward
        raise UserError(f"{p}: a TorchScript module without a forward method") from None
    for n in _script_nodes(graph):
        ns, _, op = n.kind().partition("::")
        if not ((ns == "aten" and op in SCRIPT_ATEN) or (ns == "prim" and op in SCRIPT_PRIM)):
            raise UserError(
                f"{p}: TorchScript op {n.kind()} is not one seagen reads or knows to be pure; nothing of the "
                "model was run (supported: dense layers, the activations, constant arithmetic)"
            )
