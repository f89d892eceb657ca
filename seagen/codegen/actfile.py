"""sea_act_<id>.h/.c: one actuator's constants (seagen/runtime/actq.py) rendered for the C runtime, and the
actuator an export is for."""

from __future__ import annotations

from typing import TYPE_CHECKING

from seagen.actuator import Actuator, default_actuator
from seagen.codegen.cfmt import c_int
from seagen.runtime.actq import ActQ

if TYPE_CHECKING:
    from seagen.frontends.load import Loaded

NOTES = {
    "link_shift": "table step 2^link_shift pot counts",
    "link_i32_bits": "entries below 2^k interpolate in int32",
    "pot_max": "largest pot reading",
    "travel_q": "Eq. 3 mm per encoder count, Q(16 + travel_shift)",
    "travel_shift": "enc * travel_q >> travel_shift is Q16 mm",
    "enc_i32_bits": "|enc| below 2^k multiplies in int32",
    "pot_deg_q24": "Eq. 5 deg per pot count, Q24",
    "pot_offset_q24": "Eq. 5 deg at pot 0, Q24",
    "motor_max_mv": "command limit, mV",
    "enc_jump_max": "default encoder-jump bound, counts per tick",
    "pot_stuck_ticks": "default stuck-pot ticks (100 ms)",
}


def _note(field: str, a: ActQ) -> str:
    """The comment of one sea_act field (the pot average's rate is the description's)."""
    if field == "pot_avg_ticks":
        return f"ticks per pot average ({a.control.pot_avg_hz:g} Hz)"
    return NOTES[field]


def act_files(a: ActQ) -> dict[str, str]:
    """{sea_act_<id>.h, sea_act_<id>.c} of actuator `a`."""
    from seagen.codegen.render import environment

    ctx = {
        "cid": a.cid,
        "CID": a.cid.upper(),
        "name": a.name,
        "digest": a.digest,
        "link_shift": a.link_shift,
        "link": a.link,
        "fields": [(n, c_int(v, 32), _note(n, a)) for n, v in a.struct_fields()],
    }
    env = environment()
    return {f"{a.cid}{x}": env.get_template(f"sea_act{x}.j2").render(ctx) for x in (".h", ".c")}


def export_actuator(loaded: Loaded, given: Actuator | None, where: str) -> Actuator:
    """The actuator an export is for: the one its seagen model file recorded (`loaded.actuator`: the paper's
    for a file from before the record), else the given one (a bare network or ONNX graph), else the paper's.
    A given description that disagrees with the model file's is refused (exit 2)."""
    from seagen.modelfile import same_actuator

    if loaded.actuator is None:
        return given or default_actuator()
    return same_actuator(loaded.actuator, given, where)
