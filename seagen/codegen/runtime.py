"""The hand-written C runtime (c_runtime/), found with importlib.resources after a normal install."""

from __future__ import annotations

from importlib import resources


def runtime_sources(*names: str) -> dict[str, str]:
    """{filename: text} of the named c_runtime files (e.g. 'sea_fixed.h', 'sea_fixed.c')."""
    root = resources.files("seagen.c_runtime")
    return {n: (root / n).read_text() for n in names}


FIXED = ("sea_fixed.h", "sea_fixed.c")
