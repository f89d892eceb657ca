"""Every build target by name: where a new target (or an equivalence command over all of them) plugs in."""

from __future__ import annotations

from seagen.errors import UserError
from seagen.ir import QModel
from seagen.toolchain.cortexm import CPUS, CortexM
from seagen.toolchain.model import CModel
from seagen.toolchain.target import Target

NAMES = ("host", *CPUS)


def build_target(name: str, files: dict[str, str], prefix: str, qm: QModel) -> Target:
    """The model's files built for target `name` ('host': cffi; a Cortex-M core: cross-compiled, emulated)."""
    if name == "host":
        return CModel(files, prefix, qm)
    if name in CPUS:
        return CortexM(files, prefix, qm, name)
    raise UserError(f"target must be one of {', '.join(NAMES)}, not {name!r}")
