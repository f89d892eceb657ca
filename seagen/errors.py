"""The error types the CLI turns into a clear message: bad input exits 2, a failed check exits 1."""


class UserError(ValueError):
    """Bad input from the user (a file, a row, a field, an option); the message says which and why."""


class CheckFailed(RuntimeError):
    """A check found a disagreement (e.g. the C or the integer reference against the original model)."""
