"""What a torch file holding a dict is when it is not a seagen model file: a training checkpoint or a bare
state_dict (weights without the architecture), said in one line with what to pass instead."""

from __future__ import annotations

from pathlib import Path
from typing import Any

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
