"""The fields of a model dict (a seagen model.pt, or a --features file's extra keys) checked before any is
used: each of its type, every number finite, SF powers non-negative integers up to SF_MAX_DEGREE,
texts that land in C comments safe there. Each error is one line naming the file and the field."""

from __future__ import annotations

from typing import Any

import seagen.fields as F
from seagen.cnames import comment_ascii, comment_problem, is_identifier
from seagen.errors import UserError
from seagen.ir import Signal

# a surface fit is a polynomial in its two inputs of any total degree up to this program-size cap (its
# Horner program has (degree + 1)(degree + 2) / 2 steps); below it the quantizer proves each register's
# width over the calibrated box or refuses naming the step whose bound fails (seagen.quant.sf)
SF_MAX_DEGREE = 12
TASKS = ("calibration", "control")
KINDS = ("mlp", "sf")
MAX_TEXT = 64  # longest unit or output name (printed into the generated C's comments)
SPEC_KEYS = ("input_range", "input_units", "output_name", "output_units", "output_range", "task")


def comment_text(v: Any, where: str, name: str) -> str:
    """A string printed into the generated C's comments (a unit, the output name), kept as written: the C
    spells it in ASCII (seagen.cnames.comment_ascii)."""
    s = F.text(v, where, name)
    n = max(len(s), len(comment_ascii(s)))
    if n > MAX_TEXT:
        raise F.bad(where, name, f"is {n} characters long as the C spells it (at most {MAX_TEXT})")
    if (why := comment_problem(s)) is not None:
        raise F.bad(where, name, f"{s!r} {why}")
    return s


def units(v: Any, n: int, where: str) -> list[str]:
    """input_units: one comment-safe string per input."""
    u = [comment_text(x, where, f"input_units[{i}]") for i, x in enumerate(F.seq(v, where, "input_units"))]
    if len(u) != n:
        raise UserError(f"{where}: input_units has {len(u)} entries for {n} inputs")
    return u


def ranges(v: Any, n: int, where: str) -> list[tuple[float, float]]:
    """input_range: one [lo, hi] pair of finite numbers (lo < hi) per input."""
    r = [F.pair(x, where, f"input_range[{i}]") for i, x in enumerate(F.seq(v, where, "input_range"))]
    if len(r) != n:
        raise UserError(f"{where}: input_range has {len(r)} [lo, hi] pairs for {n} inputs")
    return r


def output_signal(d: dict[str, Any], where: str) -> Signal:
    """The output: its name and unit (comment-safe) and the observed [lo, hi] (finite, lo <= hi)."""
    name = comment_text(d.get("output_name", "y"), where, "output_name")
    unit = comment_text(d.get("output_units", ""), where, "output_units")
    r = F.reals(d.get("output_range", [0.0, 0.0]), where, "output_range")
    if len(r) != 2 or not r[0] <= r[1]:
        raise F.bad(where, "output_range", f"must be a [lo, hi] pair with lo <= hi, not {list(r)}")
    return Signal(name, unit, r[0], r[1])


def task(d: dict[str, Any], where: str) -> str:
    """The task: calibration or control."""
    t = F.text(d.get("task", "calibration"), where, "task")
    if t not in TASKS:
        raise F.bad(where, "task", f"is {t!r}; it must be one of {', '.join(TASKS)}")
    return t


def kind(d: dict[str, Any], where: str) -> str:
    """The kind of a seagen model dict: mlp or sf."""
    k = F.text(d.get("kind", "mlp"), where, "kind")
    if k not in KINDS:
        raise F.bad(where, "kind", f"is {k!r}; it must be one of {', '.join(KINDS)}")
    return k


def spec_extras(d: dict[str, Any], n: int, where: str) -> None:
    """The model-dict keys a --features file may carry (SPEC_KEYS), checked where they are written: the
    spec file of n inputs."""
    if "task" in d:
        task(d, where)
    if any(k in d for k in ("output_name", "output_units", "output_range")):
        output_signal(d, where)
    if "input_units" in d:
        units(d["input_units"], n, where)
    if "input_range" in d:
        ranges(d["input_range"], n, where)


def sf_fields(sf: Any, where: str) -> tuple[tuple[str, str], tuple[tuple[int, int], ...], tuple[float, ...]]:
    """The 'sf' field: two distinct input names, powers [i, j] (distinct non-negative integers of total
    degree <= SF_MAX_DEGREE) and one finite coefficient per power."""
    sf = F.mapping(sf, where, "sf")
    for key in ("inputs", "powers", "coef"):
        if key not in sf:
            raise F.bad(where, f"sf.{key}", "is missing")
    names = F.texts(sf["inputs"], where, "sf.inputs")
    if len(names) != 2:
        raise F.bad(where, "sf.inputs", f"names {len(names)} inputs; a surface fit has 2")
    for i, n in enumerate(names):
        if not is_identifier(n):
            raise F.bad(where, f"sf.inputs[{i}]", f"{n!r} is not a C identifier (letters, digits, _)")
    if names[0].upper() == names[1].upper():
        raise F.bad(
            where,
            "sf.inputs",
            f"names {names[0]!r} and {names[1]!r}, which differ only in case (one C macro for both)",
        )
    powers: list[tuple[int, int]] = []
    for k, p in enumerate(F.seq(sf["powers"], where, "sf.powers")):
        ij = tuple(F.integer(x, where, f"sf.powers[{k}]") for x in F.seq(p, where, f"sf.powers[{k}]"))
        if len(ij) != 2 or min(ij) < 0 or sum(ij) > SF_MAX_DEGREE:
            raise F.bad(
                where,
                f"sf.powers[{k}]",
                f"is {list(ij)}; each power is [i, j], non-negative integers with i + j <= {SF_MAX_DEGREE}",
            )
        if ij in powers:
            raise F.bad(
                where, f"sf.powers[{k}]", f"repeats {list(ij)} (at {powers.index(ij)}): give each once"
            )
        powers.append((ij[0], ij[1]))
    coef = F.reals(sf["coef"], where, "sf.coef")
    if not powers or len(coef) != len(powers):
        raise UserError(
            f"{where}: field 'sf' has {len(coef)} coefficients for {len(powers)} powers "
            "(needs equal lengths, at least one)"
        )
    return (names[0], names[1]), tuple(powers), coef
