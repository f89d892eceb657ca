"""Drift named before numbers: which export a model belongs to, hand-edited, missing and stray files, other
seagen versions, and manifest fields against what verify recomputes."""

from __future__ import annotations

import math
import re
from pathlib import Path

from seagen import __version__
from seagen.codegen.manifest import Manifest, manifests_in, sha256_bytes, sha256_file
from seagen.errors import UserError, not_a_file
from seagen.verify.result import Verdict
from seagen.verify.tokens import same_tokens


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


def release(version: str) -> tuple[int, ...]:
    """The numeric release of a version string: '0.1.0' -> (0, 1, 0), '1.2rc1' -> (1, 2)."""
    return tuple(int(m.group()) for m in (re.match(r"\d+", p) for p in version.split(".")) if m)


def check_version(v: Verdict, man: Manifest) -> None:
    """A manifest from a newer seagen is refused (exit 2, its rules are unknown here); an older one warns."""
    made_by = str(man.data["seagen_version"])
    if release(made_by) > release(__version__):
        raise UserError(
            f"{man.path}: written by seagen {made_by}, newer than this seagen {__version__}; "
            f"verify with seagen >= {made_by} (pip install -U seagen)"
        )
    if made_by != __version__:
        v.warnings.append(
            f"{man.path.name} was written by seagen {made_by}; this is seagen {__version__} "
            "(its references are rebuilt and compared; a quantization change fails)"
        )


def check_model(v: Verdict, man: Manifest, model: Path, model_matches: bool) -> None:
    """Record whether MODEL is the model the export was made from."""
    want = man.data["model"]
    v.add(
        "model is the exported one",
        None
        if model_matches
        else f"{model.name} (sha256 {sha256_file(model)[:12]}) is not the model {man.path.name} was "
        f"exported from ({want['file']}, sha256 {want['sha256'][:12]})",
        kind="drift",
    )


def changed_files(folder: Path, man: Manifest) -> dict[str, str]:
    """Listed files that are missing ('missing') or whose bytes differ from the manifest ('changed')."""
    out = {}
    for name, digest in man.files.items():
        path = folder / name
        if not path.is_file():
            out[name] = "missing"
        elif sha256_file(path) != digest:
            out[name] = "changed"
    return out


def check_files(
    v: Verdict, folder: Path, man: Manifest, changed: dict[str, str], rendered: dict[str, str] | None
) -> None:
    """One check per listed file. A changed C file whose token stream equals the text this seagen writes
    for the export (and that text is the exported one, by its hash) passes with a note: whitespace,
    comments or line ends only."""
    for name in sorted(man.files):
        path, state = folder / name, changed.get(name)
        problem = None
        if state == "missing":
            problem = f"{path}: missing (listed in {man.path.name})"
        elif state == "changed":
            problem = f"{path}: edited since export (content differs from {man.path.name})"
            original = (rendered or {}).get(name)
            if (
                original is not None
                and name.endswith((".c", ".h"))
                and sha256_bytes(original.encode()) == man.files[name]
                and same_tokens(path.read_bytes().decode("utf-8", "replace"), original)
            ):
                v.notes.append(f"{path}: whitespace, comments or line ends differ from the export (same C)")
                problem = None
        v.add(f"{name} unchanged", problem, kind="drift")


def stray_files(folder: Path, man: Manifest) -> list[str]:
    """Files named NAME.* or NAME_* in the folder that no manifest there lists (a build of every *.c would
    take them in)."""
    listed: set[str] = set()
    for m in manifests_in(folder):
        listed |= {m.path.name, *m.files}
    p = man.prefix
    return sorted(
        f.name
        for f in folder.iterdir()
        if f.is_file() and f.name.startswith((f"{p}.", f"{p}_")) and f.name not in listed
    )


def check_stray(v: Verdict, folder: Path, man: Manifest) -> None:
    """Record files with the export's prefix that its manifest does not list."""
    stray = stray_files(folder, man)
    v.add(
        f"no unlisted {man.prefix}.* / {man.prefix}_* files",
        None
        if not stray
        else f"{', '.join(str(folder / s) for s in stray)}: not part of the export in {man.path.name} "
        "(remove, or re-export)",
        kind="drift",
    )


def check_fields(v: Verdict, man: Manifest, recomputed: Manifest) -> None:
    """Every manifest field that describes the export's behaviour against the manifest this seagen writes
    for the same model and options: error bound, input and output formats, options, the list of files."""
    got, want = man.data, recomputed.data
    problems = []
    bound, bound_now = got["resolved"].get("error_bound"), want["resolved"]["error_bound"]
    if not isinstance(bound, int | float) or not math.isclose(bound, bound_now, rel_tol=1e-9, abs_tol=1e-12):
        problems.append(f"error_bound {bound!r} (recomputed: {bound_now!r})")
    for key in ("inputs", "output", "features", "actuator"):
        if got["resolved"].get(key) != want["resolved"].get(key):
            problems.append(
                f"resolved.{key} {got['resolved'].get(key)!r} (recomputed: {want['resolved'][key]!r})"
            )
    for key in ("weights", "target", "controller", "onnx", "package"):
        if got["options"].get(key) != want["options"].get(key):
            problems.append(f"options.{key} {got['options'].get(key)!r} (expected {want['options'][key]!r})")
    if set(man.files) != set(recomputed.files):
        extra, lacking = set(man.files) - set(recomputed.files), set(recomputed.files) - set(man.files)
        problems.append(
            "files " + "; ".join(s for s in (_listed("lists", extra), _listed("omits", lacking)) if s)
        )
    v.add(
        fields_name(man),
        f"{man.path}: {'; '.join(problems)}" if problems else None,
        kind="drift",
    )


def fields_name(man: Manifest) -> str:
    """The stable name of the manifest-fields check."""
    return f"{man.path.name} fields match the export"


def _listed(verb: str, names: set[str]) -> str:
    """'lists a.c, b.h that this seagen does not write' style fragments."""
    if not names:
        return ""
    tail = "that this export does not write" if verb == "lists" else "that this export writes"
    return f"{verb} {', '.join(sorted(names))} {tail}"
