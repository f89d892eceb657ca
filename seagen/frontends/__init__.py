"""Frontends: torch modules, TorchScript, .pt2 and ONNX graphs -> float layers, read by what they compute."""

from __future__ import annotations

import io
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from seagen.errors import UserError
from seagen.frontends.chain import Item, to_layers
from seagen.ir import FloatLayer

TRACE_BATCH = 3  # example batch for tracing (not 0 or 1, which torch.export would specialise)


@dataclass
class Network:
    """A network as read from a file: float layers on its own inputs, and the original run by its runtime."""

    layers: list[FloatLayer]
    n_in: int
    run: Callable[[np.ndarray], np.ndarray]  # float64 (N, n_in) -> (N, n_out) through the original runtime
    runtime: str  # e.g. "torch forward (float32)"


def read_onnx(p: Path) -> Network:
    """An .onnx file: its chain by edges, and onnxruntime on the original file."""
    from seagen.frontends.onnx_reader import load_onnx, onnx_items

    model = load_onnx(p)
    items, n_in = onnx_items(p, model)
    return Network(to_layers(items, n_in, str(p)), n_in, _ort_runner(model, str(p)), "onnxruntime (float32)")


def _ort_runner(model: Any, where: str) -> Callable[[np.ndarray], np.ndarray]:
    """onnxruntime on the original graph, inputs cast to the graph input's type."""
    import onnxruntime as ort
    from onnx import helper

    try:
        sess = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    except Exception as e:  # onnxruntime raises its own types
        raise UserError(
            f"{where}: onnxruntime cannot run the original graph (the oracle needs it): {e}"
        ) from None
    inp = model.graph.input[[i.name for i in model.graph.input].index(sess.get_inputs()[0].name)]
    dtype = helper.tensor_dtype_to_np_dtype(inp.type.tensor_type.elem_type)

    def run(x: np.ndarray) -> np.ndarray:
        y = sess.run(None, {inp.name: np.asarray(x, dtype=dtype)})[0]
        return np.asarray(y, dtype=float).reshape(len(x), -1)

    return run


def read_module(obj: Any, p: Path, n_in: int) -> Network:
    """An nn.Module, a TorchScript module or an ExportedProgram -> chain -> layers."""
    import torch

    if isinstance(obj, torch.jit.ScriptModule):
        return _read_script(obj, p, n_in)
    if isinstance(obj, torch.export.ExportedProgram):
        return _read_exported(obj, obj.module(), p, _fixed_batch(obj, p))
    if isinstance(obj, torch.nn.Module):
        from seagen.frontends.torch_reader import sequential_items

        obj.eval()
        seq = sequential_items(obj)
        if seq is not None:
            run = _torch_runner(obj, None, _dtype(obj))
            return Network(to_layers(seq, n_in, str(p)), n_in, run, "torch forward")
        return _read_exported(_export(obj, p, n_in), obj, p, None)
    raise UserError(f"{p}: holds a {type(obj).__name__}, not a torch module or a seagen model file")


def _read_script(sm: Any, p: Path, n_in: int) -> Network:
    """TorchScript: its inlined graph through the TorchScript-based ONNX exporter; the original is sm."""
    from seagen.frontends.onnx_reader import onnx_items

    items, width = onnx_items(p, _script_to_onnx(sm, p, n_in))
    return Network(to_layers(items, width, str(p)), width, _torch_runner(sm, None, _dtype(sm)), "TorchScript")


def _read_exported(ep: Any, runner: Any, p: Path, fixed: int | None) -> Network:
    """An ExportedProgram's ATen graph; the original is `runner` (the module, or the program's module)."""
    from seagen.frontends.torch_reader import exported_items

    items, width = exported_items(ep, str(p))
    dtype = _user_input(ep, p).meta["val"].dtype
    return Network(
        to_layers(items, width, str(p)), width, _torch_runner(runner, fixed, dtype), "torch forward"
    )


def _dtype(m: Any) -> Any:
    """The floating dtype of a module's first parameter (float32 when it has none)."""
    import torch

    return next((q.dtype for q in m.parameters() if q.is_floating_point()), torch.float32)


def _user_input(ep: Any, p: Path) -> Any:
    """The placeholder node of an ExportedProgram's one user input."""
    users = {s.arg.name for s in ep.graph_signature.input_specs if s.kind.name == "USER_INPUT"}
    nodes = [n for n in ep.graph.nodes if n.op == "placeholder" and n.name in users]
    if len(nodes) != 1 or len(getattr(nodes[0].meta.get("val"), "shape", ())) != 2:
        raise UserError(
            f"{p}: the program takes {len(nodes)} inputs; seagen needs one (batch, features) tensor"
        )
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
            return torch.export.export(m, (torch.zeros(TRACE_BATCH, n_in, dtype=_dtype(m)),))
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


def _script_to_onnx(sm: Any, p: Path, n_in: int) -> Any:
    """TorchScript -> ONNX through the TorchScript-based (legacy) exporter, which inlines the graph."""
    import onnx
    import torch

    buf = io.BytesIO()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            torch.onnx.export(
                sm,
                (torch.zeros(TRACE_BATCH, n_in, dtype=_dtype(sm)),),
                buf,  # type: ignore[arg-type]  # the TorchScript-based exporter writes to file objects
                dynamo=False,
                input_names=["x"],
                dynamic_axes={"x": {0: "N"}},
            )
    except Exception as e:  # the exporter raises many types
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(f"{p}: cannot read the TorchScript graph on {n_in} inputs: {msg}") from None
    return onnx.load_from_string(buf.getvalue())


def _torch_runner(m: Any, fixed_batch: int | None, dtype: Any) -> Callable[[np.ndarray], np.ndarray]:
    """The module's own forward in its dtype (in chunks of the exported batch size for a .pt2)."""
    import torch

    def run(x: np.ndarray) -> np.ndarray:
        n = len(x)
        t = torch.as_tensor(np.asarray(x, dtype=np.float64)).to(dtype)
        if fixed_batch is not None:
            t = torch.cat([t, t.new_zeros(((-n) % fixed_batch, t.shape[1]))])
        with torch.no_grad():
            chunks = [t] if fixed_batch is None else list(torch.split(t, fixed_batch))
            ys = [m(c).double().numpy().reshape(len(c), -1) for c in chunks]
        return np.vstack(ys)[:n]

    return run


__all__ = ["Item", "Network", "read_module", "read_onnx"]
