"""seagen's MISRA C:2012 deviation record (explained in docs/misra.md): rule, files, the code it covers."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Deviation:
    """One recorded deviation: `rule` on the lines of files matching `files` (glob) that match `match` (regex)."""

    ident: str  # D1, D2, ... (the heading in docs/misra.md)
    rule: str  # MISRA rule (10.4) or a cppcheck id (unusedFunction)
    files: str
    match: str


RECORD: tuple[Deviation, ...] = ()
