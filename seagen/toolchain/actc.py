"""A `sea_act` built in a cffi module from the Python constants (seagen/runtime/actq.py), for host runs."""

from __future__ import annotations

from typing import Any

from seagen.runtime.actq import ActQ


class CAct:
    """A `sea_act *` and the link table it points to (both owned here: keep this object alive)."""

    def __init__(self, ffi: Any, a: ActQ) -> None:
        self.table = ffi.new("int32_t[]", list(a.link))
        self.ptr = ffi.new("sea_act *")
        self.ptr.link_q16 = self.table
        for name, value in a.struct_fields():
            setattr(self.ptr, name, value)
