"""The hand-written C runtime (c_runtime/), found with importlib.resources, and cffi declarations taken
from C headers (so no struct or prototype is declared twice)."""

from __future__ import annotations

import re
from importlib import resources

from seagen.c_runtime import COMMENT, define_of

# the C++ guard of every header (`#ifdef __cplusplus` / `extern "C" {` or `}` / `#endif`): not C
CPLUSPLUS = re.compile(r"^#ifdef __cplusplus\n.*?^#endif\n?", re.M | re.S)

# The C runtime of the controller: what NAME_controller.c and a controller tick link against.
CONTROL_RUNTIME = ("sea_pid.h", "sea_pid.c", "sea_control.h", "sea_control.c", "sea_fixed_ctrl.c")


def runtime_sources(*names: str) -> dict[str, str]:
    """{filename: text} of the named c_runtime files (e.g. 'sea_fixed.h', 'sea_fixed.c')."""
    root = resources.files("seagen.c_runtime")
    return {n: (root / n).read_text() for n in names}


def _prototypes(text: str) -> str:
    """`static inline` function definitions replaced by their prototypes (cffi calls them via its glue)."""
    out, at = [], 0
    while (i := text.find("static inline", at)) >= 0:
        brace = text.index("{", i)
        depth, j = 0, brace
        while True:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
            if depth == 0:
                break
        out.append(text[at:i] + text[i + len("static inline ") : brace].rstrip() + ";")
        at = j
    return "".join(out) + text[at:]


def cdef_of(*headers: str) -> str:
    """cffi declarations of C header texts, in order: their integer #defines, typedefs, structs and
    prototypes (of inline functions too); include guards, #includes, the C++ `extern "C"` guard and
    compile-time checks (typedefs with `?:`) are dropped."""
    out = []
    for text in headers:
        lines = []
        for line in _prototypes(CPLUSPLUS.sub("", COMMENT.sub("", text))).splitlines():
            if line.startswith("#"):
                if d := define_of(line):
                    lines.append(f"#define {d[0]} {d[1]}")
                continue
            lines.append(line)
        decls = [d for d in "\n".join(lines).split(";") if "?" not in d]
        out.append(";".join(decls))
    return "\n".join(out)


FIXED = ("sea_fixed.h", "sea_fixed.c", "sea_fixed_ctrl.c")
