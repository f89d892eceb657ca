"""The integer constants of one actuator (sea_act in C), chosen and proven here: the one place they are made.

`act_q(actuator)` turns a description (seagen/actuator.py) into the numbers the C runtime reads through a
`const sea_act *` and the Python twins read from the same object: the Eq. 2 linkage table, the pot scale and
offset (Q24 deg), the nut travel per encoder count in a Q format chosen for it, the ADC maximum, the motor's
command limit, the encoder-jump bound and the tick counts of the pot average. Each format is checked against
the ranges the runtime computes in (the bounds are stated next to each check); a geometry that does not fit
is refused with the reason (`ActuatorError`: exit 2). The generated `sea_act_<id>.h/.c` is rendered from
this object (seagen/codegen/actfile.py), so no number is written twice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from seagen.actuator import Actuator, ActuatorError, Control, default_actuator
from seagen.c_runtime import defines
from seagen.geometry import geometry

COMP_FRAC = defines("sea_fixed.h")["SEA_COMP_FRAC_BITS"]  # compression: Q16 mm
ANGLE_FRAC = defines("sea_features.h")["SEA_FEAT_ANGLE_FRAC_BITS"]  # angle: Q24 deg
# The link table has 2^8 + 1 entries whatever the ADC: its step is 2^(adc_bits - 8) counts.
LINK_INDEX_BITS = (defines("sea_fixed.h")["SEA_LINK_TABLE_LEN"] - 1).bit_length() - 1
TRAVEL_SIG_BITS = 16  # the travel constant keeps at least 16 significant bits (Q24 at the least)
TRAVEL_FRAC_MIN, TRAVEL_FRAC_MAX = 24, 46
POT_STUCK_S = 0.1  # a pot at a rail this long is stuck
ENC_JUMP_MARGIN = 2.0  # the encoder-jump bound: twice the no-load count rate per tick
CMD_MAX_MV = 2**31 - 1  # the PID command is int32 mV, its integrator Q16 in int64 (sea_pid.h)
I32_MAX = 2**31 - 1


@dataclass(frozen=True)
class ActQ:
    """sea_act: one actuator's integer constants (the field order is the C struct's)."""

    digest: str  # sha256 of the description (Actuator.digest)
    name: str  # the description's name (for comments)
    link: tuple[int, ...]  # Q16 mm, Eq. 2 linkage term every 2^link_shift pot counts, 257 entries
    link_shift: int
    link_i32_bits: int  # entries in [-2^k, 2^k) interpolate in int32: k = 30 - link_shift
    pot_max: int  # 2^adc_bits - 1
    travel_q: int  # Eq. 3: mm per encoder count in Q(travel_frac)
    travel_shift: int  # travel_frac - 16: enc * travel_q >> travel_shift is Q16 mm
    enc_i32_bits: int  # |enc| < 2^k: enc * travel_q fits int32
    pot_deg_q24: int  # Eq. 5: deg per pot count, Q24
    pot_offset_q24: int  # Eq. 5: deg at pot 0, Q24
    motor_max_mv: int  # the command limit, mV
    enc_jump_max: int  # counts per tick
    pot_avg_ticks: int  # ticks per pot average (control.pot_avg_hz)
    pot_stuck_ticks: int  # consecutive rail readings that make a fault (100 ms)
    loop_hz: float
    control: Control  # the description's force range and PID gains (SI; ControlConfig.for_act quantizes them)

    @property
    def cid(self) -> str:
        """The C name of the constant object: sea_act_ and the digest's first 32 bits as 8 letters a-p (one
        per hex digit: no digits in file or check names)."""
        return "sea_act_" + "".join("abcdefghijklmnop"[int(h, 16)] for h in self.digest[:8])

    @property
    def key(self) -> str:
        """NAME_ACT_KEY: the same 32 bits as a C literal; models with equal keys may share one pipeline."""
        return f"0x{self.digest[:8]}u"

    @property
    def table(self) -> np.ndarray:
        """The link table as an int64 array (for the twins)."""
        return np.array(self.link, dtype=np.int64)

    @property
    def travel_frac(self) -> int:
        """The Q format of travel_q."""
        return self.travel_shift + COMP_FRAC

    def struct_fields(self) -> list[tuple[str, int]]:
        """(name, value) of the scalar fields in C declaration order (the table pointer comes first)."""
        names = (
            "link_shift",
            "link_i32_bits",
            "pot_max",
            "travel_q",
            "travel_shift",
            "enc_i32_bits",
            "pot_deg_q24",
            "pot_offset_q24",
            "motor_max_mv",
            "enc_jump_max",
            "pot_avg_ticks",
            "pot_stuck_ticks",
        )
        return [(n, int(getattr(self, n))) for n in names]


def _refuse(act: Actuator, why: str) -> ActuatorError:
    """The refusal of a geometry the fixed-point runtime cannot hold."""
    return ActuatorError(f"{act.source or 'actuator'} ('{act.name}'): {why}")


def link_table(act: Actuator, shift: int) -> np.ndarray:
    """Q16 mm table of the linkage term of Eq. 2 (geometry.linkage_mm) at pot = i 2^shift, i = 0..256."""
    geo = geometry(act)
    pot = np.arange((1 << LINK_INDEX_BITS) + 1, dtype=float) * (1 << shift)
    return np.rint(geo.linkage_mm(geo.angle_from_pot(pot)) * (1 << COMP_FRAC)).astype(np.int64)


def _travel(act: Actuator) -> tuple[int, int, int]:
    """(travel_q, travel_shift, enc_i32_bits): the finest format with >= 16 significant bits, Q24 at least."""
    m = act.mm_per_count
    frac = max(TRAVEL_FRAC_MIN, TRAVEL_SIG_BITS - math.floor(math.log2(m)))
    if frac > TRAVEL_FRAC_MAX:
        raise _refuse(
            act, f"{m:.3g} mm per encoder count is below the finest travel format Q{TRAVEL_FRAC_MAX}"
        )
    q = round(m * 2.0**frac)
    # enc (any int32) * q must fit int64 (|enc| <= 2^31, q < 2^31) and q must fit its int32 field.
    if not 1 <= q <= I32_MAX:
        raise _refuse(act, f"{m:.3g} mm per encoder count does not fit Q{frac} in int32 (at most 128 mm)")
    bits = 0
    while (q << (bits + 1)) <= 2**31 and bits < 30:  # -2^k <= enc < 2^k: |enc * q| <= 2^31 (int32 path)
        bits += 1
    return q, frac - COMP_FRAC, bits


def _q24(act: Actuator, deg: float, what: str) -> int:
    """A pot constant in Q24 deg, refused unless it fits int32 (|deg| < 128)."""
    v = round(deg * 2.0**ANGLE_FRAC)
    if not -(2**31) <= v <= I32_MAX:
        raise _refuse(act, f"{what} {deg:.6g} deg does not fit Q24 in int32 (|deg| < 128)")
    return v


def _ticks(act: Actuator, hz: float, what: str) -> int:
    """round(loop_hz / hz) ticks, at least 1."""
    n = round(act.loop_hz / hz)
    if n < 1:
        raise _refuse(act, f"control.loop_hz {act.loop_hz:g} is below the {hz:g} Hz of the {what}")
    return n


def act_q(act: Actuator) -> ActQ:
    """The proven integer constants of `act`, or ActuatorError naming why the geometry is refused."""
    bits = act.pot.adc_bits
    shift = bits - LINK_INDEX_BITS
    if shift < 0:
        raise _refuse(act, f"pot.adc_bits {bits}: the link table needs at least {LINK_INDEX_BITS} bits")
    table = link_table(act, shift)
    # sea_linkage_q16: a 2^s + (b - a) f with f < 2^s in int64 needs |entry| < 2^30 (Q16: 16,384 mm).
    if int(np.abs(table).max()) >= 2**30:
        raise _refuse(act, "the linkage term of Eq. 2 reaches 16,384 mm (2^30 in Q16 mm, the table's bound)")
    travel_q, travel_shift, enc_bits = _travel(act)
    pot_deg = _q24(act, act.pot_deg_per_count, "pot.full_scale_deg per count")
    if pot_deg == 0:
        raise _refuse(act, "pot.full_scale_deg per ADC count rounds to 0 in Q24 deg")
    offset = _q24(act, act.pot.offset_deg, "pot.offset_deg")
    supply_mv = round(act.motor.supply_v * 1000.0)
    if supply_mv > CMD_MAX_MV:
        raise _refuse(act, f"motor.supply_v {act.motor.supply_v:g} V exceeds the int32 mV command")
    rate = act.motor.no_load_rpm / 60.0 * act.motor.counts_per_rev  # counts per second at no load
    jump = math.ceil(ENC_JUMP_MARGIN * rate / act.loop_hz - 1e-9)
    if not 1 <= jump <= I32_MAX:
        raise _refuse(act, f"the encoder-jump bound {jump} counts per tick does not fit int32")
    return ActQ(
        digest=act.digest(),
        name=act.name,
        link=tuple(int(v) for v in table),
        link_shift=shift,
        link_i32_bits=30 - shift,
        pot_max=act.adc_max,
        travel_q=travel_q,
        travel_shift=travel_shift,
        enc_i32_bits=enc_bits,
        pot_deg_q24=pot_deg,
        pot_offset_q24=offset,
        motor_max_mv=supply_mv,
        enc_jump_max=jump,
        pot_avg_ticks=_ticks(act, act.control.pot_avg_hz, "pot average (control.pot_avg_hz)"),
        pot_stuck_ticks=_ticks(act, 1.0 / POT_STUCK_S, "stuck-pot check"),
        loop_hz=act.loop_hz,
        control=act.control,
    )


@lru_cache(maxsize=32)
def act_q_of(act: Actuator | None = None) -> ActQ:
    """act_q of `act` (the paper's actuator when None), computed once per description."""
    return act_q(default_actuator() if act is None else act)
