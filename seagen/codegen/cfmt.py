"""C literal and identifier helpers (Jinja filters): formatting only, no arithmetic decisions."""

from __future__ import annotations

import keyword
import re
from collections.abc import Callable

import numpy as np

from seagen.errors import UserError

# The one C identifier rule for user names (inputs, the prefix): letters, digits, _, at most 31 characters.
IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,30}")
# What user text printed into a /* */ comment must not contain, and why (newlines and other control
# characters are refused separately).
COMMENT_BREAKERS = {
    "*/": "would end the comment",
    "/*": "would open a comment inside one",
    "\\": "could continue the line",
    "??": "could start a trigraph (??/ is a backslash)",
}
SIGNIFICANT = 63  # initial characters of a macro or internal identifier that C99 guarantees to distinguish
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
    if (
        not IDENT.fullmatch(prefix)
        or not prefix[0].isalpha()
        or prefix in _C_KEYWORDS
        or keyword.iskeyword(prefix)
    ):
        raise UserError(
            f"invalid prefix {prefix!r}: use a C identifier of letters, digits and '_', starting "
            "with a letter, at most 31 characters, not a C keyword"
        )
    if prefix.lower() == "sea" or prefix.lower().startswith("sea_"):
        raise UserError(
            f"invalid prefix {prefix!r}: sea and sea_* belong to the C runtime (sea_fixed, sea_nn)"
        )
    return prefix


def identifier_from(text: str) -> str:
    """A prefix made from any text (a file name): other characters become _, m_ goes before a name that does
    not start with a letter or is a C keyword or the runtime's sea/sea_*, at most 31 characters."""
    s = re.sub(r"[^A-Za-z0-9_]", "_", text)
    if not s[:1].isalpha() or s in _C_KEYWORDS or s.lower() == "sea" or s.lower().startswith("sea_"):
        s = f"m_{s}"
    return s[:31]


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


def is_identifier(name: object) -> bool:
    """Whether a user name is a C identifier seagen accepts (letters, digits, _, <= 31 characters)."""
    return isinstance(name, str) and IDENT.fullmatch(name) is not None


def input_macro(prefix: str, name: str) -> str:
    """The header macro giving an input's Q format (NAME_IN_Q_<INPUT>)."""
    return f"{prefix.upper()}_IN_Q_{name.upper()}"


def name_clashes(names: list[str], key: Callable[[str], str] = str.upper) -> list[tuple[str, str]]:
    """Pairs of distinct names that map to one C identifier under `key` (by default the upper-cased
    macro suffix: 'a' and 'A' both give NAME_IN_Q_A)."""
    seen: dict[str, str] = {}
    out = []
    for n in names:
        k = key(n)
        if k in seen and seen[k] != n:
            out.append((seen[k], n))
        seen.setdefault(k, n)
    return out


def comment_problem(text: str) -> str | None:
    """Why a user text (a unit, an output name) cannot be printed into a C comment, None if it can: it
    must be printable ASCII without '*/', '/*', a backslash or '??' (a trigraph such as ??/ is a backslash),
    so it can neither end the comment, nor continue a line, nor add a token."""
    odd = next((c for c in text if not " " <= c <= "~"), None)
    if odd is not None:
        return f"contains {odd!r} (only printable ASCII: no newline, tab or control character)"
    for seq, why in COMMENT_BREAKERS.items():
        if seq in text:
            return f"contains {seq!r}, which {why} in the generated C"
    return None


def c_comment(text: object) -> str:
    """Jinja filter for user text inside a C comment: returned unchanged when safe, else refused (the
    loaders refuse such text first, naming the file and the field; this is the guard where it lands)."""
    s = str(text)
    if (why := comment_problem(s)) is not None:
        raise UserError(f"text {s!r} cannot be written into a C comment: it {why}")
    return s


def c_ident(name: object) -> str:
    """Jinja filter for a user name used as (part of) a C identifier: returned unchanged when it is one,
    else refused (the loaders refuse it first, naming the file and the field)."""
    if not is_identifier(name):
        raise UserError(f"name {name!r} cannot be written into the C: it is not a C identifier")
    return str(name)


def check_input_macros(prefix: str, names: list[str]) -> None:
    """Refuse inputs whose Q-format macros would be one C identifier (equal, or equal in the first
    SIGNIFICANT characters C99 compilers must distinguish)."""
    for a, b in name_clashes(names, lambda n: input_macro(prefix, n)[:SIGNIFICANT]):
        raise UserError(
            f"inputs {a!r} and {b!r} give one C macro {input_macro(prefix, a)[:SIGNIFICANT]} "
            "(names must differ in more than case, within the first 63 characters of the macro)"
        )
