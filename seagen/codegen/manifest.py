"""NAME.seagen.json: what an export wrote and how, so `seagen verify` can rebuild its references exactly."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from seagen import __version__
from seagen.errors import UserError

FORMAT = "seagen-export/1"
SUFFIX = ".seagen.json"


def sha256_bytes(data: bytes) -> str:
    """Hex sha256 of bytes."""
    return hashlib.sha256(data).hexdigest()


def sha256_file(path: str | Path) -> str:
    """Hex sha256 of a file's bytes."""
    return sha256_bytes(Path(path).read_bytes())


@dataclass(frozen=True)
class Manifest:
    """The parsed manifest of one export."""

    path: Path
    data: dict[str, Any]

    @property
    def prefix(self) -> str:
        """The export's C prefix NAME."""
        return str(self.data["prefix"])

    @property
    def model_sha256(self) -> str:
        """sha256 of the model file that was exported."""
        return str(self.data["model"]["sha256"])

    @property
    def files(self) -> dict[str, str]:
        """Emitted file name -> sha256 of its bytes."""
        return dict(self.data["files"])


def manifest_text(
    prefix: str, model_path: str, options: dict[str, Any], resolved: dict[str, Any], files: dict[str, bytes]
) -> str:
    """The manifest JSON (deterministic: sorted keys, no time stamps, no absolute paths)."""
    doc = {
        "format": FORMAT,
        "seagen_version": __version__,
        "prefix": prefix,
        "model": {"file": Path(model_path).name, "sha256": sha256_file(model_path)},
        "options": options,
        "resolved": resolved,
        "files": {name: sha256_bytes(data) for name, data in sorted(files.items())},
    }
    return json.dumps(doc, indent=1, sort_keys=True) + "\n"


def read_manifest(path: Path) -> Manifest:
    """Parse one NAME.seagen.json; a malformed file is a UserError naming it."""
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise UserError(f"{path}: not a readable seagen manifest: {e}") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise UserError(f"{path}: not a seagen manifest (no format '{FORMAT}')")
    for key in ("prefix", "model", "options", "resolved", "files", "seagen_version"):
        if key not in data:
            raise UserError(f"{path}: manifest has no '{key}'")
    return Manifest(path, data)


def manifests_in(folder: Path) -> list[Manifest]:
    """Every manifest in an export folder, sorted by name."""
    return [read_manifest(p) for p in sorted(folder.glob(f"*{SUFFIX}"))]
