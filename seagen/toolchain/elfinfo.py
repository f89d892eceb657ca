"""What a linked Cortex-M image holds: stack use over its call graph, and the library helpers it links."""

from __future__ import annotations

import re
from pathlib import Path

from seagen.toolchain import cortexm as cm
from seagen.toolchain.mcu_trace import reg_count


def stack_usage(work: Path) -> dict[str, int]:
    """function -> bytes, from the -fstack-usage files of the compiled objects."""
    out = {}
    for su in work.glob("*.su"):
        for line in su.read_text().splitlines():
            loc, size, _ = line.split("\t")
            out[loc.rsplit(":", 1)[-1]] = int(size)
    return out


def _frames(text: str) -> tuple[dict[str, set[str]], dict[str, int]]:
    """From `objdump -d`: each function's callees (bl; "<indirect>" for blx rN) and the bytes its own
    pushes and `sub sp` reserve (the frame of code without -fstack-usage records, e.g. libgcc helpers)."""
    calls: dict[str, set[str]] = {}
    frame: dict[str, int] = {}
    cur = None
    for line in text.splitlines():
        if m := re.match(r"^[0-9a-f]+ <([^>]+)>:$", line):
            cur = m.group(1)
            calls[cur], frame[cur] = set(), 0
        elif cur is None:
            continue
        elif m := re.search(r"\bbl\w*\s+[0-9a-f]+ <([^>+]+)>", line):
            calls[cur].add(m.group(1))
        elif re.search(r"\bbl?x(\.n)?\s+(r\d+|ip|sl|fp|sb)\b", line):  # indirect call or tail call
            calls[cur].add("<indirect>")
        elif m := re.search(r"\t(push|stmdb)(\.w)?\s+(sp!, )?(\{[^}]*\})", line):
            frame[cur] += 4 * reg_count(m.group(4))
        elif m := re.search(r"\tsub(\.w)?\s+sp, (sp, )?#(\d+)", line):
            frame[cur] += int(m.group(3))
    return calls, frame


def static_stack(elf: Path, usage: dict[str, int], root: str) -> int | None:
    """Worst stack over the call graph from `root`: -fstack-usage records, else the function's own pushes
    and `sub sp` (libgcc helpers); indirect calls are taken to reach any NAME_predict_q16 linked. None on
    recursion."""
    calls, frame = _frames(cm._run(["arm-none-eabi-objdump", "-d", str(elf)], "objdump"))
    predictors = {f for f in calls if f.endswith("_predict_q16")}
    memo: dict[str, int | None] = {}

    def worst(f: str, path: tuple[str, ...]) -> int | None:
        if f == "<indirect>":
            return max((worst(p, path) or 0 for p in predictors), default=0)
        if f in path:
            return None  # recursion: no static bound
        if f not in memo:
            own = usage.get(f, frame.get(f, 0))
            kids = [worst(g, (*path, f)) for g in sorted(calls.get(f, ()))]
            memo[f] = None if None in kids else own + max([k or 0 for k in kids], default=0)
        return memo[f]

    return worst(root, ())


def library_helpers(elf: Path, objs: list[Path]) -> list[str]:
    """Function symbols in the image that none of our objects defines (libgcc, libc...)."""
    ours = set()
    for o in objs:
        for line in cm._run(["arm-none-eabi-nm", "--defined-only", str(o)], "nm").splitlines():
            ours.add(line.split()[-1])
    linked = cm._run(["arm-none-eabi-nm", "--defined-only", str(elf)], "nm").splitlines()
    return sorted({ln.split()[-1] for ln in linked if ln.split()[1] in "Tt"} - ours)
