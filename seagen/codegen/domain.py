"""The domain the generated C is proven on: one source for the header's macros and comments, its ACSL
contracts and the Eva harness of `seagen verify --prove` (docs/prove.md)."""

from __future__ import annotations

INT32_MIN = -(2**31)
INT32_MAX = 2**31 - 1


def c_int(v: int) -> str:
    """A C99 int32 literal of v (INT32_MIN spelled without an out-of-range constant)."""
    return "(-2147483647 - 1)" if v == INT32_MIN else str(v)


def step_domain(pot_max: int) -> list[tuple[str, int, int, str]]:
    """(name, lo, hi, what) of every raw argument of NAME_step and the controller tick: any encoder count an
    int32 holds (sea_compression_q16 widens to int64 where the int32 product could overflow), the pot's ADC
    range, any desired force (outside the calibrated range the controller faults to its safe state)."""
    return [
        ("ENC", INT32_MIN, INT32_MAX, "encoder counts: any int32"),
        ("POT", 0, pot_max, "pot counts: the ADC's range"),
        ("FORCE", INT32_MIN, INT32_MAX, "desired force, Q16 N (controller): any int32"),
    ]


def domain_macros(prefix_upper: str, pot_max: int, controller: bool) -> list[tuple[str, str, str]]:
    """(macro, C value, comment) of each bound of step_domain, e.g. NAME_POT_MAX 4095 (the desired force's
    only for a `controller` predictor)."""
    out = []
    for name, lo, hi, what in step_domain(pot_max):
        if name == "FORCE" and not controller:
            continue
        out.append((f"{prefix_upper}_{name}_MIN", c_int(lo), what))
        out.append((f"{prefix_upper}_{name}_MAX", c_int(hi), ""))
    return out
