"""The error types the CLI turns into a clear message: bad input exits 2, a failed check exits 1."""

from pathlib import Path


class UserError(ValueError):
    """Bad input from the user (a file, a row, a field, an option); the message says which and why."""


class CheckFailed(RuntimeError):
    """A check found a disagreement (e.g. the C or the integer reference against the original model)."""


def not_a_file(path: Path, what: str) -> str:
    """The message for a path that should name an existing file: it is a folder, or it does not exist."""
    return f"{path}: is a folder, not a {what}" if path.is_dir() else f"{path}: no such {what}"
