"""C literal helpers and the Jinja filters that guard user text (the rules: seagen.cnames); no arithmetic."""

from __future__ import annotations

import numpy as np

from seagen.cnames import comment_ascii, comment_problem, is_identifier
from seagen.errors import UserError


def c_int(v: int, bits: int = 32) -> str:
    """An integer literal valid for a C99 int{bits}_t, including the most negative value."""
    v = int(v)
    if bits == 64:
        return f"(INT64_C({v + 1}) - 1)" if v == -(2**63) else f"INT64_C({v})"
    if v == -(2**31):
        return "(-2147483647 - 1)"
    return str(v)


def c_array(values: object, bits: int = 16, per_line: int = 12, indent: str = "    ") -> str:
    """Comma-separated literals wrapped over lines (the body of a C array initializer)."""
    flat = [c_int(int(v), bits) for v in np.asarray(values).ravel()]
    lines = [", ".join(flat[i : i + per_line]) for i in range(0, len(flat), per_line)]
    return (",\n" + indent).join(lines)


def c_comment(text: object) -> str:
    """Jinja filter for user text inside a C comment: its ASCII spelling (N·m -> N*m) when safe, else
    refused (the loaders refuse such text first, naming the file and the field; this is the guard where it
    lands)."""
    s = str(text)
    if (why := comment_problem(s)) is not None:
        raise UserError(f"text {s!r} cannot be written into a C comment: it {why}")
    return comment_ascii(s)


def c_ident(name: object) -> str:
    """Jinja filter for a user name used as (part of) a C identifier: returned unchanged when it is one,
    else refused (the loaders refuse it first, naming the file and the field)."""
    if not is_identifier(name):
        raise UserError(f"name {name!r} cannot be written into the C: it is not a C identifier")
    return str(name)
