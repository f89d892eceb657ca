"""Hand-written C runtime shipped as package data (see README.md here); its headers own the constants."""

from __future__ import annotations

import re
from functools import cache
from importlib import resources

COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)
_DEFINE = re.compile(r"^#define\s+([A-Za-z_]\w*)\s+\(?\s*(-?\d+)\s*\)?\s*$")


def header_text(name: str) -> str:
    """The text of one c_runtime file (e.g. 'sea_fixed.h')."""
    return (resources.files(__name__) / name).read_text()


def define_of(line: str) -> tuple[str, int] | None:
    """(NAME, value) of a comment-free `#define NAME <int>` line (value maybe parenthesized), else None."""
    m = _DEFINE.match(line.strip())
    return (m.group(1), int(m.group(2))) if m else None


@cache
def defines(name: str) -> dict[str, int]:
    """The integer constants of a c_runtime header: their one definition, which Python reads."""
    lines = COMMENT.sub("", header_text(name)).splitlines()
    return dict(d for d in map(define_of, lines) if d is not None)
