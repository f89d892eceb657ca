"""C literal and identifier helpers (Jinja filters): formatting only, no arithmetic decisions."""

from __future__ import annotations

import keyword
import re

import numpy as np

from seagen.errors import UserError

_IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,30}$")
_C_KEYWORDS = {
    "auto",
    "break",
    "case",
    "char",
    "const",
    "continue",
    "default",
    "do",
    "double",
    "else",
    "enum",
    "extern",
    "float",
    "for",
    "goto",
    "if",
    "inline",
    "int",
    "long",
    "register",
    "restrict",
    "return",
    "short",
    "signed",
    "sizeof",
    "static",
    "struct",
    "switch",
    "typedef",
    "union",
    "unsigned",
    "void",
    "volatile",
    "while",
}


def assert_valid_prefix(prefix: str) -> str:
    """A C identifier usable as the prefix of every emitted symbol (letters, digits, _, <= 31 chars),
    outside the runtime's own `sea` namespace."""
    if not prefix:
        raise UserError("--prefix is empty: give a C identifier such as cal_mlp")
    if not _IDENT.match(prefix) or prefix in _C_KEYWORDS or keyword.iskeyword(prefix):
        raise UserError(
            f"invalid prefix {prefix!r}: use a C identifier of letters, digits and '_', starting "
            "with a letter, at most 31 characters, not a C keyword"
        )
    if prefix.lower() == "sea" or prefix.lower().startswith("sea_"):
        raise UserError(
            f"invalid prefix {prefix!r}: sea and sea_* belong to the C runtime (sea_fixed, sea_nn)"
        )
    return prefix


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
