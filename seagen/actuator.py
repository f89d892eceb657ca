"""The actuator description: one validated TOML file holding every geometry number of a linear SEA.

Fields and units (the paper's actuator, `seagen/actuators/paper.toml`, is the default):

    kind                         "linear" (lead screw + compression spring); "rotary" reserved, refused today
    name                         free text
    [motor] supply_v             V      motor supply (the command range is +-supply_v)
            no_load_rpm          rpm    no-load speed of the motor shaft at supply_v
            gear_ratio           -      gearbox reduction (motor turns per output turn)
            counts_per_rev       count  encoder counts per motor revolution (integer)
            stall_force_n        N      nut force that stalls the motor at supply_v (stall torque x gear
                                        ratio x 2 pi / lead, less the screw's losses)
            time_constant_s      s      first-order lag of the nut speed behind the command (electrical +
                                        rotor inertia through the gearbox)
    [transmission] lead_mm       mm     nut travel per gearbox output revolution
                   friction_n    N      actuator friction at the output shaft, measured as in the paper's
                                        Fig. 7: the constant the textbook (kinematics) estimate compensates
    [spring] stiffness_n_per_mm  N/mm   series spring stiffness k_s
    [linkage] cb_mm              mm     the lever CB of Eq. 2 (its constant offset CE is not a field: with the
                                        spring unloaded at home_deg it cancels out of the compression)
              home_deg           deg    contact angle at rest with the spring unloaded
              angle_min_deg, angle_max_deg, split_deg   deg   contact-angle range; H_fit below the split
              h_fit              -      R_l below the split, ascending powers of (angle - angle_min_deg)
              v_fit_higher       -      R_l above the split: powers >= 2 of (angle - split_deg)
    [pot] full_scale_deg         deg    angle change over the whole ADC range (2^adc_bits counts)
          offset_deg             deg    angle at ADC count 0
          adc_bits               bit    ADC resolution (8..16)
          vref_mv                mV     the ADC's reference: the pot's voltage at full scale (optional;
                                        a rig that logs the pot in mV reads it as counts with it)
    [control] loop_hz            Hz     controller tick rate
              force_max_n        N      top of the calibrated desired-force range at the output shaft (the
                                        controller faults above it; the experiment's targets are fractions;
                                        at most motor.stall_force_n)
              kp_v_per_mm        V/mm       PID proportional gain on the compression error
              ki_v_per_mm_s      V/(mm s)   integral gain
              kd_v_s_per_mm      V s/mm     derivative gain, on the filtered compression rate
              d_alpha            -          derivative filter coefficient in (0, 1] (1: no filter)
              margin_mm          mm         control margin: no P action, integrator held within it
              limit_v            V          command limit (at most motor.supply_v; left out, or equal to
                                            the paper's 6.5 V: capped at the supply by the controller)
              pot_avg_hz         Hz         rate at which the controller refreshes its block average of
                                            the pot (the average spans loop_hz / pot_avg_hz ticks)
    pot.vref_mv and the [control] fields after loop_hz are optional: a file without one takes the paper's
    value (seagen/actuators/paper.toml: gains tuned on its simulated plant; tune yours on your plant with
    `python -m seagen.control.tune --actuator FILE`). A value equal to that default is left out of the
    recorded values and the hash, so descriptions and model files written before these fields existed keep
    their hash.

Errors name the file and the field (`ActuatorError`, a user error: exit 2).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import tomllib
from dataclasses import asdict, dataclass
from functools import lru_cache
from importlib import resources
from typing import Any

from seagen.errors import UserError
from seagen.fields import read_toml


class ActuatorError(UserError):
    """An actuator description that cannot be used (names the file and the field)."""


@dataclass(frozen=True)
class Motor:
    """The drive motor and its encoder."""

    supply_v: float
    no_load_rpm: float
    gear_ratio: float
    counts_per_rev: int
    stall_force_n: float
    time_constant_s: float


@dataclass(frozen=True)
class Linkage:
    """Eq. 2 lengths, the contact-angle range and the force ratio R_l of Eq. 6."""

    cb_mm: float
    home_deg: float
    angle_min_deg: float
    angle_max_deg: float
    split_deg: float
    h_fit: tuple[float, ...]
    v_fit_higher: tuple[float, ...]


@dataclass(frozen=True)
class Pot:
    """The linkage-angle potentiometer and its ADC."""

    full_scale_deg: float
    offset_deg: float
    adc_bits: int
    vref_mv: float


@dataclass(frozen=True)
class Control:
    """The control loop's optional settings: desired-force range and PID gains (SI units)."""

    force_max_n: float
    kp_v_per_mm: float
    ki_v_per_mm_s: float
    kd_v_s_per_mm: float
    d_alpha: float
    margin_mm: float
    limit_v: float
    pot_avg_hz: float


@dataclass(frozen=True)
class Actuator:
    """A linear SEA as seagen sees it; derived quantities are properties."""

    kind: str
    name: str
    motor: Motor
    lead_mm: float
    friction_n: float
    stiffness_n_per_mm: float
    linkage: Linkage
    pot: Pot
    loop_hz: float
    control: Control
    source: str = dataclasses.field(
        default="", compare=False, repr=False
    )  # the file it was read from (messages only)

    @property
    def mm_per_count(self) -> float:
        """Nut travel per encoder count (Eq. 3)."""
        return self.lead_mm / (self.motor.gear_ratio * self.motor.counts_per_rev)

    @property
    def pot_deg_per_count(self) -> float:
        """Linkage angle per pot ADC count (Eq. 4-5)."""
        return self.pot.full_scale_deg / float(2**self.pot.adc_bits)

    @property
    def adc_max(self) -> int:
        """The largest pot reading."""
        return 2**self.pot.adc_bits - 1

    def to_dict(self) -> dict[str, Any]:
        """The parsed values in the file's layout (what a model file records; actuator_from_dict reads it)."""
        return {
            "kind": self.kind,
            "name": self.name,
            "motor": asdict(self.motor),
            "transmission": {"lead_mm": self.lead_mm, "friction_n": self.friction_n},
            "spring": {"stiffness_n_per_mm": self.stiffness_n_per_mm},
            "linkage": {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self.linkage).items()},
            "pot": asdict(self.pot),
            "control": {"loop_hz": self.loop_hz, **asdict(self.control)},
        }

    def recorded(self) -> dict[str, Any]:
        """to_dict without the optional values that equal their defaults (what the hash covers)."""
        d = self.to_dict()
        for table, opt in _OPTIONAL.items():
            d[table] = {k: v for k, v in d[table].items() if k not in opt or v != opt[k]}
        return d

    def digest(self) -> str:
        """sha256 of the recorded values (formatting, comments and defaulted optional fields do not count)."""
        return hashlib.sha256(json.dumps(self.recorded(), sort_keys=True).encode()).hexdigest()

    def differences(self, other: Actuator, most: int = 3) -> str:
        """The fields `other` gives otherwise, as 'table.field X, not Y' (at most `most`, then a count)."""
        mine, theirs = self.to_dict(), other.to_dict()
        out = []
        for table, fields in mine.items():
            if not isinstance(fields, dict):
                if fields != theirs[table]:
                    out.append(f"{table} {theirs[table]!r}, not {fields!r}")
                continue
            out += [
                f"{table}.{k} {theirs[table][k]!r}, not {v!r}"
                for k, v in fields.items()
                if v != theirs[table][k]
            ]
        out = [x for x in out if not x.startswith("name ")] or out  # the messages show both names
        more = f" and {len(out) - most} more" if len(out) > most else ""
        return "; ".join(out[:most]) + more

    def record(self) -> dict[str, Any]:
        """What a model file stores: the parsed values and their hash (`actuator_from_record` reads it)."""
        return {"values": self.recorded(), "sha256": self.digest()}


_TABLES: dict[str, dict[str, type]] = {
    "motor": {
        "supply_v": float,
        "no_load_rpm": float,
        "gear_ratio": float,
        "counts_per_rev": int,
        "stall_force_n": float,
        "time_constant_s": float,
    },
    "transmission": {"lead_mm": float, "friction_n": float},
    "spring": {"stiffness_n_per_mm": float},
    "linkage": {
        "cb_mm": float,
        "home_deg": float,
        "angle_min_deg": float,
        "angle_max_deg": float,
        "split_deg": float,
        "h_fit": list,
        "v_fit_higher": list,
    },
    "pot": {"full_scale_deg": float, "offset_deg": float, "adc_bits": int},
    "control": {"loop_hz": float},
}
_CONTROL_FIELDS = tuple(Control.__dataclass_fields__)
_POT_FIELDS = tuple(Pot.__dataclass_fields__)


PAPER_FILE = "seagen/actuators/paper.toml"


def _paper_toml() -> dict[str, Any]:
    """The paper's description file (package data), parsed."""
    text = resources.files("seagen.actuators").joinpath("paper.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


# The optional fields' defaults per table: the paper's values, from its description file.
_OPTIONAL: dict[str, dict[str, float]] = {
    table: {k: float(v) for k, v in _paper_toml()[table].items() if k in names and k not in _TABLES[table]}
    for table, names in (("pot", _POT_FIELDS), ("control", _CONTROL_FIELDS))
}


def _value(where: str, field: str, value: Any, kind: type) -> Any:
    """One field, type-checked and finite."""
    if kind is list:
        if not isinstance(value, list) or not value:
            raise ActuatorError(f"{where}: '{field}' must be a non-empty array of numbers")
        return tuple(_value(where, f"{field}[{i}]", v, float) for i, v in enumerate(value))
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ActuatorError(f"{where}: '{field}' must be a number, got {value!r}")
    if kind is int and not isinstance(value, int):
        raise ActuatorError(f"{where}: '{field}' must be an integer, got {value!r}")
    if not math.isfinite(value):
        raise ActuatorError(f"{where}: '{field}' must be finite, got {value!r}")
    return kind(value)


def _tables(data: dict[str, Any], where: str) -> dict[str, dict[str, Any]]:
    """Every table and field present, of its type, and nothing unknown."""
    unknown = set(data) - set(_TABLES) - {"kind", "name"}
    if unknown:
        raise ActuatorError(
            f"{where}: unknown key '{sorted(unknown)[0]}' (known: kind, name, {', '.join(_TABLES)})"
        )
    out: dict[str, dict[str, Any]] = {}
    for table, spec in _TABLES.items():
        got = data.get(table)
        if not isinstance(got, dict):
            raise ActuatorError(f"{where}: missing table [{table}]")
        known = [*spec, *_OPTIONAL.get(table, ())]
        extra = set(got) - set(known)
        if extra:
            raise ActuatorError(
                f"{where}: unknown key '{table}.{sorted(extra)[0]}' (known: {', '.join(known)})"
            )
        out[table] = {}
        for key, kind in spec.items():
            if key not in got:
                raise ActuatorError(f"{where}: missing '{table}.{key}'")
            out[table][key] = _value(where, f"{table}.{key}", got[key], kind)
    for table, opt in _OPTIONAL.items():
        got = data[table]
        out[table].update({k: _value(where, f"{table}.{k}", got.get(k, v), float) for k, v in opt.items()})
    return out


def _check(a: Actuator, where: str) -> Actuator:
    """Physical plausibility: positive sizes, an ordered angle range, a usable ADC, a command limit within
    the supply and a force range the motor can reach."""
    positive = {
        "motor.supply_v": a.motor.supply_v,
        "motor.no_load_rpm": a.motor.no_load_rpm,
        "motor.gear_ratio": a.motor.gear_ratio,
        "motor.counts_per_rev": a.motor.counts_per_rev,
        "motor.stall_force_n": a.motor.stall_force_n,
        "motor.time_constant_s": a.motor.time_constant_s,
        "transmission.lead_mm": a.lead_mm,
        "spring.stiffness_n_per_mm": a.stiffness_n_per_mm,
        "linkage.cb_mm": a.linkage.cb_mm,
        "pot.full_scale_deg": a.pot.full_scale_deg,
        "pot.vref_mv": a.pot.vref_mv,
        "control.loop_hz": a.loop_hz,
        "control.pot_avg_hz": a.control.pot_avg_hz,
        "control.force_max_n": a.control.force_max_n,
        "control.limit_v": a.control.limit_v,
    }
    for field, v in positive.items():
        if v <= 0:
            raise ActuatorError(f"{where}: '{field}' must be positive, got {v!r}")
    if a.friction_n < 0:
        raise ActuatorError(f"{where}: 'transmission.friction_n' must be >= 0, got {a.friction_n!r}")
    lk = a.linkage
    if not lk.angle_min_deg < lk.split_deg < lk.angle_max_deg:
        raise ActuatorError(f"{where}: 'linkage': need angle_min_deg < split_deg < angle_max_deg")
    if not lk.angle_min_deg <= lk.home_deg <= lk.angle_max_deg:
        raise ActuatorError(f"{where}: 'linkage.home_deg' must lie in [angle_min_deg, angle_max_deg]")
    if not 0.0 < lk.angle_max_deg < 90.0:
        raise ActuatorError(f"{where}: 'linkage.angle_max_deg' must lie in (0, 90) deg")
    c = a.control
    for field in ("kp_v_per_mm", "ki_v_per_mm_s", "kd_v_s_per_mm", "margin_mm"):
        if getattr(c, field) < 0:
            raise ActuatorError(f"{where}: 'control.{field}' must be >= 0, got {getattr(c, field)!r}")
    if c.limit_v > a.motor.supply_v and c.limit_v != _OPTIONAL["control"]["limit_v"]:  # default: capped
        raise ActuatorError(
            f"{where}: 'control.limit_v' {c.limit_v:g} V is above 'motor.supply_v' {a.motor.supply_v:g} V "
            "(the command limit must lie within +-supply_v)"
        )
    if c.force_max_n > a.motor.stall_force_n:
        dflt = "" if c.force_max_n != _OPTIONAL["control"]["force_max_n"] else " (the paper's default)"
        raise ActuatorError(
            f"{where}: 'control.force_max_n' {c.force_max_n:g} N{dflt} is above 'motor.stall_force_n' "
            f"{a.motor.stall_force_n:g} N: the motor cannot push that hard, so the calibration data and the "
            "controller would not reach the top of the range (set control.force_max_n below the stall force)"
        )
    if not 0.0 < c.d_alpha <= 1.0:
        raise ActuatorError(f"{where}: 'control.d_alpha' must lie in (0, 1], got {c.d_alpha!r}")
    if not 8 <= a.pot.adc_bits <= 16:
        raise ActuatorError(f"{where}: 'pot.adc_bits' must be 8..16, got {a.pot.adc_bits}")
    return a


def actuator_from_dict(data: dict[str, Any], where: str = "<dict>") -> Actuator:
    """Validate a parsed description; every error names `where` and the field."""
    kind = data.get("kind", "linear")
    if kind != "linear":
        raise ActuatorError(f"{where}: 'kind' {kind!r} is not supported (only \"linear\" SEAs today)")
    name = data.get("name", "")
    if not isinstance(name, str):
        raise ActuatorError(f"{where}: 'name' must be a string")
    t = _tables(data, where)
    act = Actuator(
        kind=kind,
        name=name,
        motor=Motor(**t["motor"]),
        lead_mm=t["transmission"]["lead_mm"],
        friction_n=t["transmission"]["friction_n"],
        stiffness_n_per_mm=t["spring"]["stiffness_n_per_mm"],
        linkage=Linkage(**t["linkage"]),
        pot=Pot(**t["pot"]),
        loop_hz=t["control"]["loop_hz"],
        control=Control(**{k: t["control"][k] for k in _CONTROL_FIELDS}),
        source=where,
    )
    return _check(act, where)


def to_toml(act: Actuator, note: str = "") -> str:
    """The parsed values as a description file (what `data generate` / `data import` keep beside the data)."""
    import tomli_w

    head = "# seagen actuator description (fields: seagen/actuator.py)" + (f"; {note}" if note else "")
    return head + "\n" + tomli_w.dumps(act.to_dict())


def load_actuator(path: str | os.PathLike[str]) -> Actuator:
    """Read and validate an actuator description (TOML)."""
    return actuator_from_dict(read_toml(path, ActuatorError), str(path))


@lru_cache(maxsize=1)
def default_actuator() -> Actuator:
    """The paper's actuator, shipped as package data (`seagen/actuators/paper.toml`)."""
    return actuator_from_dict(_paper_toml(), PAPER_FILE)


def is_default(act: Actuator) -> bool:
    """Whether `act` is the paper's actuator (a description with its values, from any file)."""
    return act.digest() == default_actuator().digest()


def actuator_from_record(record: Any, where: str) -> Actuator:
    """The description a model file recorded, validated and its hash checked (`where` names the file)."""
    if not isinstance(record, dict) or set(record) != {"values", "sha256"}:
        raise ActuatorError(f"{where}: 'actuator' must hold exactly 'values' and 'sha256'")
    if not isinstance(record["values"], dict):
        raise ActuatorError(f"{where}: 'actuator.values' must be a table")
    act = actuator_from_dict(record["values"], f"{where}: actuator")
    if act.digest() != record["sha256"]:
        raise ActuatorError(f"{where}: 'actuator.sha256' does not match the recorded values")
    return dataclasses.replace(act, source=where)
