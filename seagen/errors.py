"""The one error type the CLI turns into a clear message and exit code 2."""


class UserError(ValueError):
    """Bad input from the user (a file, a row, a field, an option); the message says which and why."""
