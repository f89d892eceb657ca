"""Open torch files without running their code: each recognised by its content, archives checked member by
member against an allow-list before torch sees them, pickles read weights-only."""

from __future__ import annotations

import io
import warnings
from pathlib import Path
from typing import Any

from seagen.errors import UserError
from seagen.filekind import EXPORT, TORCHSCRIPT, file_kind
from seagen.modelfile import safe_load


def load_torch(p: Path, allow_pickle: bool = False) -> Any:
    """A .pt/.pth (seagen model dict, nn.Module), TorchScript archive or .pt2 ExportedProgram, whatever its
    name. Without allow_pickle a .pt2 is rebuilt from its JSON program and raw tensors (never through
    torch.export.load) and a TorchScript archive reaches torch.jit.load only after every member passed."""
    kind = file_kind(p)
    if kind not in (EXPORT, TORCHSCRIPT):
        return safe_load(p, allow_pickle)
    import torch

    from seagen.frontends.archives import check_script_ops, check_torchscript
    from seagen.frontends.pt2_reader import read_pt2

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if allow_pickle:  # the user's opt-in: torch's own readers, which can run code the file carries
                if kind == EXPORT:
                    return torch.export.load(str(p))
                return torch.jit.load(str(p), map_location="cpu")
            if kind == EXPORT:
                return read_pt2(p)
            checked = check_torchscript(p)  # the checked members, repacked: torch reads only those
            module = torch.jit.load(io.BytesIO(checked), map_location="cpu")
            check_script_ops(module, p)  # before anything of it runs (ONNX conversion folds, the oracle runs)
            return module
    except UserError:
        raise
    except Exception as e:  # torch raises many types for unreadable archives
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(f"{p}: not a readable TorchScript or .pt2 archive: {msg}") from None
