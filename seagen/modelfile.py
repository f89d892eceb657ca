"""The one model file (`model.pt`): a torch.save'd dict that every later stage reads.

Contract (keys of the saved dict; `seagen.fit` writes it, `seagen export` and `seagen evaluate` read it):

    format          "seagen-model/1"
    kind            "mlp" | "sf"
    task            "calibration" (sensors -> force at the shaft, N) | "control" (desired force + sensors
                    -> desired compression, mm)
    module          for "mlp": the torch.nn.Sequential (Linear + ReLU/LeakyReLU/Hardtanh/Tanh/Sigmoid) that
                    maps *normalized* inputs to the *normalized* output
    sf              for "sf": {"inputs": [a, b], "powers": [[i, j], ...], "coef": [...]} — a 3rd-order
                    polynomial in the two raw (un-normalized) inputs, output in output units
    features        FeatureSpec.to_dict(): input names in order, normalization, the difference scheme
    input_units     list of unit strings, one per input
    output_name     e.g. "force_n" or "compression_mm";  output_units: "N" | "mm"
    input_range     [[lo, hi], ...] observed on the training data (raw units), one per input
    output_range    [lo, hi] observed on the training data (output units)
    loss            "mse" | "mae";  seed: int;  hidden: list[int] (mlp);  metrics: dict
    actuator        Actuator.record(): the description the training data came from (parsed values + sha256);
                    absent in files written before it existed, which mean the paper's actuator
"""

from __future__ import annotations

import contextlib
import os
import zipfile
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from seagen.actuator import Actuator, ActuatorError, actuator_from_record, default_actuator
from seagen.errors import UserError, not_a_file
from seagen.filekind import EXPORT, ONNX, TORCHSCRIPT, file_kind, pickle_globals

FORMAT = "seagen-model/1"
DIFFERENCE_SCHEME = "backward; d=x[n]-x[n-1], dd=x[n]-2x[n-1]+x[n-2]; warm-up x[-1]=x[-2]=x[0]"


@dataclass(frozen=True)
class FeatureSpec:
    """How the model's inputs come from raw signals: x_model = (x_raw - mean) / std * weight."""

    inputs: tuple[str, ...]
    mean: tuple[float, ...]
    std: tuple[float, ...]
    weight: tuple[float, ...] = ()  # per-input weights (control predictor, paper §VI-C); () = all 1
    output_mean: float = 0.0  # y = y_model * output_std + output_mean
    output_std: float = 1.0
    raw: tuple[str, ...] = ("enc", "pot")
    differences: str = DIFFERENCE_SCHEME
    sample_rate_hz: float = field(default_factory=lambda: default_actuator().loop_hz)  # files before the rate
    extra: dict[str, Any] = field(default_factory=dict)

    def weights(self) -> tuple[float, ...]:
        """Per-input weights, 1.0 where none were given."""
        return self.weight if self.weight else tuple(1.0 for _ in self.inputs)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict for the model file."""
        return asdict(self)

    @staticmethod
    def from_dict(d: dict[str, Any], where: str = "feature spec") -> FeatureSpec:
        """Parse and check a feature spec (a model file's or a --features JSON/TOML): each field of its type,
        every number finite, every std > 0, input names distinct C identifiers; errors name the field."""
        import seagen.fields as F
        from seagen.cnames import is_identifier, name_clashes

        d = F.mapping(d, where, "features")
        if "inputs" not in d:
            raise F.bad(where, "inputs", "is missing (the model's input names, in order)")
        names = F.texts(d["inputs"], where, "inputs")
        n = len(names)
        if n == 0:
            raise F.bad(where, "inputs", "is empty")
        for i, name in enumerate(names):
            if not is_identifier(name):
                raise F.bad(where, f"inputs[{i}]", f"{name!r} is not a C identifier (letters, digits, _)")
        twice = sorted({x for x in names if names.count(x) > 1})
        if twice:
            raise UserError(f"{where}: 'inputs' names {', '.join(map(repr, twice))} more than once")
        if clash := name_clashes(list(names)):
            a, b = clash[0]
            raise F.bad(
                where, "inputs", f"names {a!r} and {b!r}, which differ only in case (one C macro for both)"
            )
        vec = {}
        for key, default, check in (
            ("mean", 0.0, F.real),
            ("std", 1.0, F.positive),
            ("weight", None, F.real),
        ):
            if key not in d:
                vec[key] = () if default is None else (default,) * n
                continue
            vals = tuple(check(v, where, f"{key}[{i}]") for i, v in enumerate(F.seq(d[key], where, key)))
            if len(vals) != n and (key != "weight" or vals):
                raise UserError(f"{where}: '{key}' has {len(vals)} values for {n} inputs")
            vec[key] = vals
        extra = F.mapping(d.get("extra", {}), where, "extra")
        return FeatureSpec(
            inputs=names,
            mean=vec["mean"],
            std=vec["std"],
            weight=vec["weight"],
            output_mean=F.real(d.get("output_mean", 0.0), where, "output_mean"),
            output_std=F.positive(d.get("output_std", 1.0), where, "output_std"),
            raw=F.texts(d.get("raw", ("enc", "pot")), where, "raw"),
            differences=F.text(d.get("differences", DIFFERENCE_SCHEME), where, "differences"),
            sample_rate_hz=F.positive(
                d.get("sample_rate_hz", default_actuator().loop_hz), where, "sample_rate_hz"
            ),
            extra=dict(extra),
        )


def save_model(obj: dict[str, Any], path: str | os.PathLike[str]) -> None:
    """Write a model dict atomically."""
    import torch

    from seagen.atomic import atomic_path

    obj = {"format": FORMAT, **obj}
    with atomic_path(path) as tmp:
        torch.save(obj, tmp)


def nn_allowlist() -> list[Any]:
    """What a model.pt (or an nn.Sequential saved whole) may contain: torch.nn layers and numpy scalars."""
    import numpy as np
    import torch.nn as nn

    # numpy scalars pickle as multiarray.scalar(dtype, bytes): data only, no code
    numeric = (np.float64, np.float32, np.int64, np.int32, np.bool_)
    return [
        nn.Sequential, nn.Linear, nn.ReLU, nn.ReLU6, nn.LeakyReLU, nn.Hardtanh, nn.Tanh, nn.Sigmoid,
        nn.Identity, nn.Dropout, nn.BatchNorm1d, nn.Flatten,
        # the smooth and piecewise-linear activations: float (GELU: a str) attributes, PReLU a weight tensor
        nn.ELU, nn.SELU, nn.Softplus, nn.GELU, nn.Mish, nn.SiLU, nn.Hardsigmoid, nn.Hardswish, nn.PReLU,
        np.float64(0).__reduce__()[0], np.dtype, *(type(np.dtype(t)) for t in numeric),
    ]  # fmt: skip


PICKLE_HINT = (
    "it holds Python objects seagen will not unpickle (loading a pickle can run any code); "
    "if you trust this file, pass --allow-pickle"
)
NN_LAYERS = "torch.nn.modules."


def safe_load(p: Path, allow_pickle: bool = False) -> Any:
    """torch.load with weights_only=True and the torch.nn allowlist. Only the user's explicit --allow-pickle
    (allow_pickle=True: every caller passes the command's store_true flag, never a default) unpickles, which
    RUNS the code the file carries (export, evaluate, verify, simulate, pil)."""
    import torch

    if allow_pickle:  # --allow-pickle was given: full unpickling, the one place seagen runs a file's code
        with _readable(p):
            return torch.load(p, map_location="cpu", weights_only=False)  # only under allow_pickle
    with _readable(p), torch.serialization.safe_globals(nn_allowlist()):
        return torch.load(p, map_location="cpu", weights_only=True)


@contextlib.contextmanager
def _readable(p: Path) -> Iterator[None]:
    """torch's many exception types for a corrupt or refused file as one UserError naming the file."""
    try:
        yield
    except Exception as e:
        text = str(e)
        if "weights_only" in text or "Unsupported global" in text or "Unpickler" in text:
            raise UserError(f"{p}: {refusal(p)}") from None
        first = text.strip().splitlines()[0] if text.strip() else type(e).__name__
        raise UserError(f"{p}: not a readable torch file: {first}") from None


def refusal(p: Path) -> str:
    """Why weights-only loading refused a file, naming the first class it stopped at (read statically):
    a torch.nn layer seagen does not export is said to be unsupported (--allow-pickle would not help);
    anything else is code only --allow-pickle unpickles."""
    import torch

    try:
        with zipfile.ZipFile(p) as z:
            pkl = next(n for n in z.namelist() if n.endswith("/data.pkl") or n == "data.pkl")
            names = pickle_globals(z.read(pkl))
    except (zipfile.BadZipFile, StopIteration):
        try:
            names = pickle_globals(p.read_bytes())
        except ValueError:
            return PICKLE_HINT
    except (OSError, ValueError):
        return PICKLE_HINT
    from torch import _weights_only_unpickler as wo

    with torch.serialization.safe_globals(nn_allowlist()):
        allowed = {*wo._get_allowed_globals(), *wo._get_user_allowed_globals()}
    unsafe = [g for g in names if g not in allowed]
    code = [g for g in unsafe if not g.startswith(NN_LAYERS)]
    if code:
        return f"it needs {code[0]}, which is not a torch.nn layer seagen reads; {PICKLE_HINT}"
    if unsafe:
        layer = unsafe[0].rsplit(".", 1)[-1]
        return (
            f"it holds a torch.nn.{layer} layer, which seagen does not export (--allow-pickle would not "
            f"change that); supported layers: {', '.join(SUPPORTED)}"
        )
    return PICKLE_HINT


SUPPORTED = (
    "Linear", "ReLU", "LeakyReLU", "Hardtanh", "ReLU6", "Tanh", "Sigmoid", "BatchNorm1d", "Dropout",
    "Identity", "Flatten", "ELU", "SELU", "Softplus", "GELU", "Mish", "SiLU", "Hardsigmoid", "Hardswish",
    "PReLU",
)  # fmt: skip


def load_model(path: str | os.PathLike[str], allow_pickle: bool = False) -> dict[str, Any]:
    """Read a seagen model file without running code; errors name the file."""
    p = Path(path)
    if not p.is_file():
        raise UserError(not_a_file(p, "model file"))
    if file_kind(p) in (ONNX, TORCHSCRIPT, EXPORT):
        raise UserError(
            f"{p}: not a seagen model file: this command reads the model.pt of `seagen train` "
            "(`seagen export` and `seagen verify` take TorchScript, .pt2 and .onnx models too)"
        )
    obj = safe_load(p, allow_pickle)
    if isinstance(obj, dict) and obj.get("format") != FORMAT:
        raise UserError(describe_dict(obj, p, FORMAT))  # a checkpoint or state_dict: say what it is
    if not isinstance(obj, dict):
        raise UserError(f"{p}: not a seagen model file (no format '{FORMAT}')")
    return obj


# What a torch file holding a dict is when it is not a seagen model file: a training checkpoint or a
# bare state_dict (weights without the architecture), said in one line with what to pass instead.
INSTEAD = (
    "pass the network itself: torch.save(model) of an nn.Sequential, torch.jit.script(model).save(...), "
    "torch.export.save(...) (.pt2) or torch.onnx.export(...)"
)
CHECKPOINT_KEYS = ("model_state_dict", "state_dict", "model", "net", "model_state")
TRAINING_KEYS = ("optimizer_state_dict", "optimizer", "epoch", "step", "scheduler", "loss")


def is_state_dict(obj: Any) -> bool:
    """A non-empty mapping of parameter names ('0.weight', 'fc1.bias', ...) to tensors."""
    import torch

    return (
        isinstance(obj, dict)
        and bool(obj)
        and all(isinstance(k, str) for k in obj)
        and all(isinstance(v, torch.Tensor) for v in obj.values())
    )


def describe_dict(obj: dict[Any, Any], p: Path, fmt: str) -> str:
    """The one-line message for a dict that is not a seagen model file (format `fmt`)."""
    if is_state_dict(obj):
        return (
            f"{p}: a bare state_dict ({len(obj)} tensors such as '{next(iter(obj))}'): weights without "
            f"the architecture, which seagen cannot read; {INSTEAD}"
        )
    inner = next((k for k in CHECKPOINT_KEYS if is_state_dict(obj.get(k))), None)
    if inner is not None:
        extra = [k for k in TRAINING_KEYS if k in obj]
        keys = ", ".join([inner, *extra])
        return (
            f"{p}: a training checkpoint ({keys}): weights without the architecture, which seagen cannot "
            f"read; {INSTEAD}"
        )
    return f"{p}: a dict but not a seagen model file (no format '{fmt}'); {INSTEAD}"


def model_actuator(model: dict[str, Any], where: str, given: Actuator | None = None) -> Actuator:
    """The actuator a model was trained for (the paper's when the file predates the record); a `given`
    description that disagrees with the recorded one is refused, naming both."""
    rec = model.get("actuator")
    return same_actuator(
        default_actuator() if rec is None else actuator_from_record(rec, where), given, where
    )


def same_actuator(act: Actuator, given: Actuator | None, where: str) -> Actuator:
    """`act`, the description a model is for; a `given` one that disagrees is refused, naming both."""
    if given is not None and given.digest() != act.digest():
        raise ActuatorError(
            f"{where}: the model was trained for actuator '{act.name}' (sha256 {act.digest()[:12]}), "
            f"not the given '{given.name}' (sha256 {given.digest()[:12]}): the given one has "
            f"{act.differences(given)}"
        )
    return act
