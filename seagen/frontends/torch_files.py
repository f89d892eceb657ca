"""Open torch files without running their code: weights-only unpickling, .pt2 archives inspected first."""

from __future__ import annotations

import io
import warnings
import zipfile
from pathlib import Path
from typing import Any

from seagen.errors import UserError
from seagen.modelfile import PICKLE_HINT, is_pt2, is_torchscript, safe_load, zip_members


def load_torch(p: Path, allow_pickle: bool = False) -> Any:
    """A .pt/.pth (seagen model dict, nn.Module), TorchScript archive or .pt2 ExportedProgram."""
    import torch

    names = zip_members(p)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if is_pt2(names):
                if not allow_pickle:
                    check_pt2(p, names)
                return torch.export.load(str(p))
            if is_torchscript(names):
                return torch.jit.load(str(p), map_location="cpu")
    except UserError:
        raise
    except Exception as e:  # torch raises many types for unreadable archives
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(f"{p}: not a readable TorchScript or .pt2 archive: {msg}") from None
    return safe_load(p, allow_pickle)


def check_pt2(p: Path, names: list[str]) -> None:
    """Refuse a .pt2 whose pickled members (sample inputs, constants, weights) need more than tensors."""
    import json

    import torch

    with zipfile.ZipFile(p) as z:
        for n in names:
            if n.endswith(("model_weights_config.json", "model_constants_config.json")):
                cfg = json.loads(z.read(n)).get("config", {})
                for key, meta in cfg.items():
                    if meta.get("use_pickle") or not str(meta.get("path_name", "")).startswith(
                        ("weight_", "tensor_")
                    ):
                        raise UserError(f"{p}: entry '{key}' of {n} is a pickled object; {PICKLE_HINT}")
            elif "/sample_inputs/" in n or n.endswith((".pkl", "constants.pt")):
                try:
                    torch.load(io.BytesIO(z.read(n)), weights_only=True)
                except Exception:  # anything the weights-only unpickler rejects
                    raise UserError(f"{p}: member {n}: {PICKLE_HINT}") from None
