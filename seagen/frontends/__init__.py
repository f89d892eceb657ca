"""Frontends: torch modules, TorchScript, .pt2 and ONNX graphs -> float layers, read by what they compute."""

from __future__ import annotations

import io
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from seagen.errors import UserError
from seagen.frontends.chain import Item, to_layers
from seagen.ir import FloatLayer

TRACE_BATCH = 3  # example batch for tracing (not 0 or 1, which torch.export would specialise)
LOW_FLOATS = ("float16", "bfloat16")  # originals whose margin is measured against their float32 twin


@dataclass
class Network:
    """A network as read from a file: float layers on its own inputs, and the original run by its runtime."""

    layers: list[FloatLayer]
    n_in: int
    run: Callable[[np.ndarray], np.ndarray]  # float64 (N, n_in) -> (N, n_out) through the original runtime
    runtime: str  # e.g. "torch forward (float32)"
    dtype: str = "float32"  # the narrowest float type the original computes in (its rounding sets the margin)
    notes: list[str] = field(default_factory=list)  # one line each: how the file was read, when not literally
    # a float16/bfloat16 original run with its tensors widened to float32 (its own rounding is measured
    # against it: seagen.frontends.margin.rounding_margin); None for float32/float64 originals
    wide: Callable[[np.ndarray], np.ndarray] | None = None
    wide_whole: bool = False  # the twin widens every tensor and cast (ONNX): equal outputs are float32's


def read_onnx(p: Path) -> Network:
    """An .onnx file: its chain by edges, and onnxruntime on the original file."""
    from seagen.frontends.onnx_file import inlined, load_onnx
    from seagen.frontends.onnx_reader import onnx_items

    model = load_onnx(p)
    flat = inlined(model, p)  # local functions expanded (read); the original file is what onnxruntime runs
    items, n_in, feed = onnx_items(p, flat)
    dtype = onnx_dtype(flat)
    run = _ort_runner(model, str(p), feed)
    net = Network(to_layers(items, n_in, str(p)), n_in, run, f"onnxruntime ({dtype})", dtype)
    if flat is not model:
        names = ", ".join(sorted({f.name for f in model.functions}))
        net.notes.append(f"note: {p.name}: local functions ({names}) inlined by onnx.inliner before reading")
    if dtype in LOW_FLOATS:
        from seagen.frontends.onnx_file import widened_to_float32

        net.wide = _ort_runner(widened_to_float32(flat), str(p), feed)
        net.wide_whole = True
    return net


def onnx_dtype(model: Any) -> str:
    """The narrowest float type among the graph's inputs, outputs, initializers, constants and cast targets
    (float32 when there is none): the rounding the original may add."""
    from onnx import TensorProto

    names = {TensorProto.DOUBLE: "float64", TensorProto.FLOAT: "float32"}
    names |= {TensorProto.FLOAT16: "float16", TensorProto.BFLOAT16: "bfloat16"}
    g = model.graph
    types = [i.type.tensor_type.elem_type for i in [*g.input, *g.output]]
    types += [t.data_type for t in g.initializer]
    for n in g.node:
        types += [a.i for a in n.attribute if n.op_type == "Cast" and a.name == "to"]
        types += [a.t.data_type for a in n.attribute if n.op_type == "Constant" and a.name == "value"]
    return narrowest([names[t] for t in types if t in names])


def narrowest(dtypes: list[str]) -> str:
    """The float type with the largest unit roundoff among the names given (float32 for none)."""
    from seagen.frontends.margin import UNIT_ROUNDOFF

    return max(dtypes or ["float32"], key=lambda d: UNIT_ROUNDOFF[d])


def _first_line(e: BaseException) -> str:
    """The first line of an exception's message (its type when it has none); for an error raised inside a
    TorchScript forward, its last line (the original exception, after the TorchScript traceback)."""
    lines = [ln.strip() for ln in str(e).strip().splitlines() if ln.strip()]
    if not lines:
        return type(e).__name__
    if "TorchScript interpreter" in lines[0]:
        raised = [ln for ln in lines if re.match(r"[\w.]*(Error|Exception): ", ln)]
        return raised[-1] if raised else lines[-1]
    return lines[0]


def _ort_runner(model: Any, where: str, feed: Any) -> Callable[[np.ndarray], np.ndarray]:
    """onnxruntime on the original graph, rows laid out as its input (`feed`, seagen.frontends.onnx_shapes)
    in its type; a graph that takes a fixed number of rows gets runs of that size (the last one padded)."""
    import onnxruntime as ort
    from onnx import helper

    from seagen.frontends.onnx_shapes import split_parts

    try:
        sess = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    except Exception as e:  # onnxruntime raises its own types
        raise UserError(
            f"{where}: onnxruntime cannot run the original graph (the oracle needs it): {_first_line(e)}"
        ) from None
    first = feed.parts[0][0] if feed.parts else feed.name  # inputs a Concat joins share one type
    inp = model.graph.input[[i.name for i in model.graph.input].index(first)]
    dtype = helper.tensor_dtype_to_np_dtype(inp.type.tensor_type.elem_type)

    def once(x: np.ndarray) -> np.ndarray:
        try:
            xs = np.asarray(x, dtype=dtype).reshape(feed.layout(len(x)))
            y = sess.run(None, split_parts(feed, xs))[0]
        except Exception as e:  # onnxruntime raises its own types
            raise UserError(
                f"{where}: onnxruntime failed running the original graph: {_first_line(e)}"
            ) from None
        return np.asarray(y, dtype=float).reshape(len(x), -1)

    return once if feed.rows is None else batched(once, feed.rows)


def batched(run: Callable[[np.ndarray], np.ndarray], size: int) -> Callable[[np.ndarray], np.ndarray]:
    """Run a fixed-batch original on any number of rows: batches of `size`, the last padded with its own
    first row, the padding dropped from the result."""

    def run_all(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x)
        n = len(x)
        if n == 0:
            return np.zeros((0, 1))
        pad = (-n) % size
        xs = np.concatenate([x, np.repeat(x[:1], pad, axis=0)]) if pad else x
        return np.vstack([run(xs[i : i + size]) for i in range(0, len(xs), size)])[:n]

    return run_all


def read_module(obj: Any, p: Path, n_in: int) -> Network:
    """An nn.Module, a TorchScript module or an ExportedProgram -> chain -> layers."""
    import torch

    if isinstance(obj, torch.jit.ScriptModule):
        return _read_script(obj, p, n_in)
    if isinstance(obj, torch.export.ExportedProgram):
        return _read_exported(obj, obj.module(), p, _fixed_batch(obj, p))
    if isinstance(obj, torch.nn.Module):
        from seagen.frontends.torch_reader import sequential_items

        notes = _eval_mode(obj, p)
        seq = sequential_items(obj)
        if seq is not None:
            d = _dn(_dtype(obj))
            run = _torch_runner(obj, None, _in_dtype(obj), str(p))
            net = Network(to_layers(seq, n_in, str(p)), n_in, run, f"torch forward ({d})", d, notes)
            net.wide = _wide_torch(obj, None, d, str(p))
            return net
        net = _read_exported(_export(obj, p, n_in), obj, p, None)
        net.notes = notes
        return net
    raise UserError(f"{p}: holds a {type(obj).__name__}, not a torch module or a seagen model file")


def _read_script(sm: Any, p: Path, n_in: int) -> Network:
    """TorchScript: its inlined graph through the TorchScript-based ONNX exporter; the original is sm (in
    eval mode, the inference behaviour)."""
    from seagen.frontends.onnx_reader import onnx_items

    notes = _eval_mode(sm, p)
    n_args = len(list(sm.forward.graph.inputs())) - 1  # without self
    if n_args > 1:
        items, width, parts = _script_joined(sm, p, n_in, n_args)
    else:
        items, width, _feed = onnx_items(p, _script_to_onnx(sm, p, n_in))
        parts = None
    d = _dn(_dtype(sm))
    run = _torch_runner(sm, None, _in_dtype(sm), str(p), parts)
    net = Network(to_layers(items, width, str(p)), width, run, f"TorchScript ({d})", d, notes)
    net.wide = _wide_torch(sm, None, d, str(p))
    return net


def _eval_mode(m: Any, p: Path) -> list[str]:
    """Switch a module saved in training mode to eval mode (what inference runs: Dropout off, BatchNorm on
    its running statistics); the one-line note that says so, or none."""
    training = any(c.training for c in m.modules())
    m.eval()
    if not training:
        return []
    return [
        f"note: {p.name} was saved in training mode; exported its inference (eval-mode) behaviour "
        "(Dropout off, BatchNorm on running statistics)"
    ]


def _read_exported(ep: Any, runner: Any, p: Path, fixed: int | None) -> Network:
    """An ExportedProgram's ATen graph; the original is `runner` (the module, or the program's module)."""
    from seagen.frontends.joined import joined_inputs
    from seagen.frontends.torch_reader import exported_items

    items, width = exported_items(ep, str(p))
    d_in = _user_input(ep, p).meta["val"].dtype
    weights = [_dn(v.dtype) for v in ep.state_dict.values() if v.is_floating_point()]
    d = narrowest([_dn(d_in), *weights])
    joined = joined_inputs(ep, str(p))
    run = _torch_runner(runner, fixed, d_in, str(p), joined[1] if joined else None)
    net = Network(to_layers(items, width, str(p)), width, run, f"torch forward ({d})", d)
    net.wide = _wide_torch(runner, fixed, d, str(p), joined[1] if joined else None)
    return net


def _wide_torch(
    m: Any, fixed: int | None, dtype: str, where: str, parts: Any = None
) -> Callable[[np.ndarray], np.ndarray] | None:
    """A float16/bfloat16 module's float32 twin (a copy with its parameters and buffers widened), run like
    the original; None for a wider module or one that cannot be copied."""
    import copy

    import torch

    if dtype not in LOW_FLOATS:
        return None
    try:
        twin = copy.deepcopy(m).float()
    except Exception:  # a module that cannot be copied: the margin falls back to the analytic bound
        return None
    return _torch_runner(twin, fixed, torch.float32, where, parts)


def _dtype(m: Any) -> Any:
    """The narrowest floating dtype of a module's parameters and buffers (float32 when it has none)."""
    import torch

    ds = {q.dtype for q in [*m.parameters(), *m.buffers()] if q.is_floating_point()}
    return max(ds, key=lambda d: torch.finfo(d).eps) if ds else torch.float32


def _in_dtype(m: Any) -> Any:
    """The floating dtype of a module's first parameter (what its forward takes; float32 when none)."""
    import torch

    return next((q.dtype for q in m.parameters() if q.is_floating_point()), torch.float32)


def _dn(d: Any) -> str:
    """torch.float16 -> 'float16'."""
    return str(d).removeprefix("torch.")


def _user_input(ep: Any, p: Path) -> Any:
    """The placeholder node of an ExportedProgram's one user input (the first of inputs it concatenates
    into one: seagen.frontends.joined)."""
    from seagen.frontends.joined import joined_inputs, user_placeholders

    nodes = user_placeholders(ep)
    if len(nodes) != 1 and (len(nodes) < 2 or joined_inputs(ep, str(p)) is None):
        raise UserError(
            f"{p}: the program takes {len(nodes)} inputs; seagen needs one (batch, features) tensor"
        )
    if any(len(getattr(n.meta.get("val"), "shape", ())) != 2 for n in nodes):
        raise UserError(f"{p}: the program's input is not (batch, features); seagen needs one such tensor")
    return nodes[0]


def _fixed_batch(ep: Any, p: Path) -> int | None:
    """The batch size a loaded program was exported for (its module only runs that size), None if dynamic."""
    b = _user_input(ep, p).meta["val"].shape[0]
    return int(b) if isinstance(b, int) else None


def _export(m: Any, p: Path, n_in: int) -> Any:
    """torch.export of an eval-mode module on an example batch (torch's own error logging silenced)."""
    import logging

    import torch

    log = logging.getLogger("torch")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return torch.export.export(m, (torch.zeros(TRACE_BATCH, n_in, dtype=_in_dtype(m)),))
    except Exception as e:  # export raises many types for modules it cannot follow
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        first = next((x for x in m.modules() if isinstance(x, torch.nn.Linear)), None)
        hint = f" (its first Linear takes {first.in_features} inputs)" if first is not None else ""
        raise UserError(
            f"{p}: torch.export cannot run the module's forward on the {n_in} inputs the feature "
            f"specification names{hint}: {msg}"
        ) from None
    finally:
        log.setLevel(level)


def _script_joined(sm: Any, p: Path, n_in: int, n_args: int) -> tuple[list[Item], int, Any]:
    """A TorchScript forward of several (batch, width) tensors that it concatenates along the features
    (forward(a, b): torch.cat([a, b], 1)): the first split of the n_in features into its arguments that
    exports and reads as a Concat of the graph's inputs (any such split computes the same function of the
    joined row); the chain, its width and the parts (argument, width) the original's rows split into."""
    from itertools import combinations

    from seagen.frontends.onnx_reader import onnx_items

    last = f"its forward takes {n_args} tensors"
    for cuts in combinations(range(1, n_in), n_args - 1):
        widths = [b - a for a, b in zip((0, *cuts), (*cuts, n_in), strict=True)]
        try:
            items, width, feed = onnx_items(p, _script_to_onnx(sm, p, n_in, widths))
        except UserError as e:
            last = str(e).removeprefix(f"{p}: ")
            continue
        if feed.parts:
            return items, width, [(int(name[1:]), w) for name, w in feed.parts]
    raise UserError(
        f"{p}: cannot read the TorchScript forward of {n_args} inputs as one feature vector joined by "
        f"torch.cat along the features ({last})"
    )


def _script_to_onnx(sm: Any, p: Path, n_in: int, widths: list[int] | None = None) -> Any:
    """TorchScript -> ONNX through the TorchScript-based (legacy) exporter, which inlines the graph; with
    `widths`, a forward of several inputs (x0, x1, ...) of those widths."""
    import onnx
    import torch

    buf = io.BytesIO()
    names = [f"x{k}" for k in range(len(widths))] if widths else ["x"]
    example = tuple(torch.zeros(TRACE_BATCH, w, dtype=_in_dtype(sm)) for w in (widths or [n_in]))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            torch.onnx.export(
                sm,
                example,
                buf,  # type: ignore[arg-type]  # the TorchScript-based exporter writes to file objects
                dynamo=False,
                input_names=names,
                dynamic_axes={n: {0: "N"} for n in names},
            )
    except Exception as e:  # the exporter raises many types
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(f"{p}: cannot read the TorchScript graph on {n_in} inputs: {msg}") from None
    return onnx.load_from_string(buf.getvalue())


def _torch_runner(
    m: Any, fixed_batch: int | None, dtype: Any, where: str, parts: Any = None
) -> Callable[[np.ndarray], np.ndarray]:
    """The module's own forward in its dtype (in batches of the exported batch size for a .pt2; the row's
    columns split into the inputs a program concatenates, `parts`); an error the forward raises is one line
    naming the file."""
    import torch

    from seagen.frontends.joined import split_args

    def run(x: np.ndarray) -> np.ndarray:
        t = torch.as_tensor(np.asarray(x, dtype=np.float64)).to(dtype)
        try:
            with torch.no_grad():
                return m(*split_args(t, parts)).double().numpy().reshape(len(x), -1)
        except Exception as e:  # any forward can raise anything
            raise UserError(
                f"{where}: the model's own forward failed (the oracle needs it): {_first_line(e)}"
            ) from None

    return run if fixed_batch is None else batched(run, fixed_batch)


__all__ = ["Item", "Network", "read_module", "read_onnx"]
