"""Drift named before numbers: which export a model belongs to, hand-edited files, other seagen versions."""

from __future__ import annotations

from pathlib import Path

from seagen import __version__
from seagen.codegen.manifest import Manifest, manifests_in, sha256_file
from seagen.errors import UserError, not_a_file
from seagen.verify.result import Verdict


def select(folder: Path, model: Path, prefix: str | None) -> tuple[Manifest, bool]:
    """The manifest to verify and whether MODEL is the model it was exported from.

    With --prefix, that export; otherwise the one whose model hash matches MODEL, or the only export in the
    folder (then a different model is drift, not bad input). Several or no candidates: exit 2, named.
    """
    if not folder.is_dir():
        raise UserError(f"{folder}: no such export folder")
    if not model.is_file():
        raise UserError(not_a_file(model, "model file"))
    found = manifests_in(folder)
    if not found:
        raise UserError(f"{folder}: no export manifest (*.seagen.json); re-export with seagen export")
    digest = sha256_file(model)
    if prefix is not None:
        named = [m for m in found if m.prefix == prefix]
        if not named:
            raise UserError(f"{folder}: no export '{prefix}' (found: {', '.join(m.prefix for m in found)})")
        return named[0], named[0].model_sha256 == digest
    matching = [m for m in found if m.model_sha256 == digest]
    if len(matching) == 1:
        return matching[0], True
    if len(matching) > 1:
        names = ", ".join(m.path.name for m in matching)
        raise UserError(f"{folder}: several exports of {model.name} ({names}); choose one with --prefix")
    if len(found) == 1:
        return found[0], False
    names = ", ".join(m.path.name for m in found)
    raise UserError(f"{folder}: no export of {model.name} among {names} (model hash {digest[:12]})")


def check_drift(v: Verdict, folder: Path, man: Manifest, model: Path, model_matches: bool) -> None:
    """Record the model, file and version drift of one export in the verdict."""
    want = man.data["model"]
    v.add(
        "model is the exported one",
        None
        if model_matches
        else f"{model.name} (sha256 {sha256_file(model)[:12]}) is not the model {man.path.name} was "
        f"exported from ({want['file']}, sha256 {want['sha256'][:12]})",
        kind="drift",
    )
    for name, digest in sorted(man.files.items()):
        path = folder / name
        if not path.is_file():
            problem: str | None = f"{path}: missing (listed in {man.path.name})"
        elif sha256_file(path) != digest:
            problem = f"{path}: edited since export (content differs from {man.path.name})"
        else:
            problem = None
        v.add(f"{name} unchanged", problem, kind="drift")
    made_by = man.data["seagen_version"]
    if made_by != __version__:
        v.warnings.append(
            f"{man.path.name} was written by seagen {made_by}; this is seagen {__version__} "
            "(its references are rebuilt and compared; a quantization change fails)"
        )
