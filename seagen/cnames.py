"""What user text may become in the C: the one identifier rule, the prefix, macro names, comment-safe text."""

from __future__ import annotations

import keyword
import re
import unicodedata
from collections.abc import Callable

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
# How the C comments spell non-ASCII characters people write in units (N·m, °, µm, Ω, m/s²); any other
# character is spelled by its compatibility decomposition without accents (é -> e, ℃ -> degC) when that is
# ASCII, else as <U+XXXX>. The text itself is kept as written (in the manifest, in messages).
ASCII_SPELLING = {
    "\u00b7": "*",  # middle dot
    "\u22c5": "*",  # dot operator
    "\u2219": "*",  # bullet operator
    "\u00d7": "x",  # multiplication sign
    "\u00b0": "deg",  # degree sign
    "\u00b5": "u",  # micro sign
    "\u03bc": "u",  # Greek small mu
    "\u03a9": "Ohm",  # Greek capital omega (NFKD of the ohm sign U+2126)
    "\u00b1": "+/-",
    "\u2212": "-",  # minus sign
    "\u2013": "-",  # en dash
    "\u221a": "sqrt",
    "\u2044": "/",  # fraction slash (NFKD of ½)
}
_SUPERSCRIPTS = "\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079\u207b\u207a"  # ⁰¹²³⁴⁵⁶⁷⁸⁹⁻⁺
_SUPERSCRIPT = str.maketrans(_SUPERSCRIPTS, "0123456789-+")
_SUPERSCRIPT_RUN = re.compile(f"[{_SUPERSCRIPTS}]+")
# Unicode categories refused outright: control, format (bidi overrides, zero-width), surrogate, private,
# unassigned, line and paragraph separators
_UNPRINTABLE = ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp")
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


def comment_ascii(text: str) -> str:
    """User text as the generated C's comments spell it: ASCII unchanged, superscripts as ^2 or ^-1, other
    characters by ASCII_SPELLING, their accent-free compatibility decomposition, or <U+XXXX>."""
    s = _SUPERSCRIPT_RUN.sub(lambda m: "^" + m.group().translate(_SUPERSCRIPT), text)
    s = "".join(c for c in unicodedata.normalize("NFKD", s) if not unicodedata.combining(c))
    return "".join(_ascii_char(c) for c in s)


def _ascii_char(c: str) -> str:
    """One character of NFKD text in ASCII (see comment_ascii)."""
    if c.isascii():
        return c
    return ASCII_SPELLING.get(c, f"<U+{ord(c):04X}>")


def comment_problem(text: str) -> str | None:
    """Why a user text (a unit, an output name) cannot be printed into a C comment, None if it can: no
    control, format or line-separator character, and its ASCII spelling (comment_ascii) printable without
    '*/', '/*', a backslash or '??' (a trigraph such as ??/ is a backslash), so it can neither end the
    comment, nor continue a line, nor add a token."""
    odd = next((c for c in text if unicodedata.category(c) in _UNPRINTABLE), None)
    if odd is not None:
        return f"contains {odd!r} (only printable text: no newline, tab, control or format character)"
    spelled = comment_ascii(text)
    how = "" if spelled == text else f"written in the C as {spelled!r}, "
    for seq, why in COMMENT_BREAKERS.items():
        if seq in spelled:
            return f"{how}contains {seq!r}, which {why} in the generated C"
    return None


def check_input_macros(prefix: str, names: list[str]) -> None:
    """Refuse inputs whose Q-format macros would be one C identifier (equal, or equal in the first
    SIGNIFICANT characters C99 compilers must distinguish)."""
    for a, b in name_clashes(names, lambda n: input_macro(prefix, n)[:SIGNIFICANT]):
        raise UserError(
            f"inputs {a!r} and {b!r} give one C macro {input_macro(prefix, a)[:SIGNIFICANT]} "
            "(names must differ in more than case, within the first 63 characters of the macro)"
        )
