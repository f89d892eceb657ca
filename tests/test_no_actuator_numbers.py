"""No number of the paper's actuator is written into seagen's Python, C runtime or templates: they read the
description (seagen/actuators/paper.toml through seagen/actuator.py). The numbers are taken from the
description itself (and what follows from it: counts per turn, ADC maximum, supply in mV, ...); code is
scanned token by token (Python through its syntax tree, so comments and docstrings do not count; C and
templates with comments and strings removed), with constant expressions such as `380 * 12` folded."""

from __future__ import annotations

import ast
import math
import operator
import re
from pathlib import Path

import pytest

from seagen.actuator import Actuator, default_actuator
from seagen.control.experiment import CONTACT_MARGIN_DEG, TARGET_FRACTIONS
from seagen.discrepancy.bench import TRUTH
from seagen.discrepancy.families import FAMILIES
from seagen.discrepancy.recalibrate import PLAUSIBLE_SHARES

# The ranges of pot counts (as shares of full scale) the catalogue's benchmarks and checks use.
POT_RANGES = (
    TRUTH["pot_voltage_drop"]["counts_per_unit_current"],
    PLAUSIBLE_SHARES["pot_voltage_drop"]["counts_per_unit_current"],
    FAMILIES["lagged_pot_bias"].ranges["gain"],
)

REPO = Path(__file__).resolve().parents[1]
SCANNED = ("seagen", "c_runtime", "templates")
# The description and its loader: the one place the numbers live.
EXEMPT = ("seagen/actuator.py", "seagen/actuators/")
# (file, value) -> why that literal there is not the actuator's number. Keep it short.
ALLOWED: dict[tuple[str, float], str] = {
    ("seagen/plant/config.py", 2.7): "the effect catalogue's default Coulomb friction (plant.toml's effect, "
    "separate from the description by design; the description's friction_n is what the estimate subtracts)",
    ("seagen/plant/config.py", 0.55): "actuator_friction.reverse_ratio, an effect parameter (not h_fit[0])",
    ("seagen/pil/fw/pil_common.c", 28): "interrupt vector 28 in the PIL firmware's vector table",
    ("seagen/data/protocol.py", 4.2): "the validation move's push volts on the paper's motor (scaled like "
    "every move on another design), not spring.stiffness_n_per_mm",
    (
        "seagen/frontends/margin.py",
        4096,
    ): "the number of box points a float16 original's rounding is measured on, not 2^pot.adc_bits",
    (
        "seagen/plant/kernel.py",
        28,
    ): "a row index of the compiled kernel's parameter table, not linkage.angle_max_deg",
    (
        "seagen/plant/kernel.py",
        36,
    ): "a row index of the compiled kernel's parameter table, not linkage.cb_mm",
    ("seagen/discrepancy/signature.py", 0.025): "the signature's 'under load' band as a share of the force "
    "range (the paper's 0.5 N of 20 N), not control.margin_mm",
}


def forbidden(act: Actuator) -> dict[float, str]:
    """value -> what it is: the description's distinctive numbers and the ones that follow from them.

    Not scanned, as too common to mean the actuator: supply 12 V, 12 CPR and 12 bits (Q12 gains, sqrt(12)),
    the 5 deg home / minimum and -5 deg offset, the 16 deg split, the 20 mm lead and 20 N range, the 100 Hz
    loop, the 150 N stall force, the 15 ms time constant, kp 31 (2^31), ki 6.5 / limit 6.5 V, d_alpha 0.95;
    the encoder-jump bound 130 (exit code of SIGINT)."""
    m, lk, c = act.motor, act.linkage, act.control
    out = {
        m.no_load_rpm: "motor.no_load_rpm",
        m.gear_ratio: "motor.gear_ratio",
        m.gear_ratio * m.counts_per_rev: "encoder counts per gearbox output turn (Eq. 3)",
        act.mm_per_count: "mm of nut travel per encoder count (Eq. 3)",
        round(act.mm_per_count * 2**24): "mm per encoder count in Q24 (the old SEA_MM_PER_COUNT_Q24)",
        act.friction_n: "transmission.friction_n",
        act.stiffness_n_per_mm: "spring.stiffness_n_per_mm",
        1.0 / act.stiffness_n_per_mm: "1 / spring.stiffness_n_per_mm",
        lk.cb_mm: "linkage.cb_mm",
        lk.angle_max_deg: "linkage.angle_max_deg",
        act.pot.full_scale_deg: "pot.full_scale_deg",
        act.pot_deg_per_count: "pot degrees per count (Eq. 4-5)",
        act.adc_max: "the largest pot reading, 2^adc_bits - 1",
        act.adc_max + 1: "2^pot.adc_bits",
        act.adc_max - 1: "one below the pot's top rail",
        round(m.supply_v * 1000): "motor.supply_v in mV",
        c.kd_v_s_per_mm: "control.kd_v_s_per_mm",
        c.margin_mm: "control.margin_mm",
        act.pot.vref_mv: "pot.vref_mv (the pot's ADC reference, mV)",
    }
    for i, h in enumerate(lk.h_fit):
        out.setdefault(abs(h), f"linkage.h_fit[{i}]")
    for i, v in enumerate(lk.v_fit_higher):
        out.setdefault(abs(v), f"linkage.v_fit_higher[{i}]")
    return out


def groups(act: Actuator) -> dict[tuple[float, ...], str]:
    """Numbers that are the actuator's only together (one line holding all of them)."""
    lk = act.linkage
    lo, hi = lk.angle_min_deg + CONTACT_MARGIN_DEG[0], lk.angle_max_deg - CONTACT_MARGIN_DEG[1]
    targets = tuple(f * act.control.force_max_n for f in TARGET_FRACTIONS)
    fs = act.adc_max + 1.0  # the catalogue's pot counts: shares of the pot's full scale
    pot = {(lo * fs, hi * fs) for lo, hi in POT_RANGES}
    return {
        (lo, hi): "the experiment's contact-angle range",
        targets: "the experiment's force targets",
        **{r: "a range of pot counts of the effect catalogue (a share of the pot's full scale)" for r in pot},
    }


def same(v: float, target: float) -> bool:
    """Integers exactly; other numbers to 1e-4 (a literal rounded to 4-5 digits is still the number)."""
    v = abs(v)
    if float(target).is_integer():
        return v == target
    return math.isclose(v, target, rel_tol=1e-4)


_FOLD = {
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Pow: operator.pow,
    ast.LShift: operator.lshift,
}


def _fold(node: ast.AST) -> float | None:
    """The value of a constant numeric expression (literals, unary minus, + - * / ** <<), else None."""
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        v = _fold(node.operand)
        return None if v is None else -v
    if isinstance(node, ast.BinOp) and type(node.op) in _FOLD:
        a, b = _fold(node.left), _fold(node.right)
        if a is None or b is None or (isinstance(node.op, ast.Pow | ast.LShift) and abs(b) > 64):
            return None
        try:
            return _FOLD[type(node.op)](a, b)
        except (ZeroDivisionError, TypeError, ValueError):
            return None
    return None


def python_numbers(text: str) -> list[tuple[int, float]]:
    """(line, value) of every numeric literal and constant expression in Python source."""
    out = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Constant | ast.BinOp | ast.UnaryOp):
            v = _fold(node)
            if v is not None and not isinstance(v, bool):
                out.append((node.lineno, float(v)))
    return out


_C_NOISE = re.compile(r"/\*.*?\*/|//[^\n]*|\{#.*?#\}|\"(?:\\.|[^\"\\\n])*\"|'(?:\\.|[^'\\\n])+'", re.S)
_C_NUM = r"(?:0[xX][0-9a-fA-F]+|(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)[uUlLfF]*"
_C_TOKEN = re.compile(rf"(?<![\w.])({_C_NUM})(?![\w.])")
_C_PRODUCT = re.compile(rf"(?<![\w.])({_C_NUM})\s*(\*|<<)\s*({_C_NUM})(?![\w.])")


def _c_value(tok: str) -> float:
    """A C literal's value (suffixes dropped)."""
    tok = tok.rstrip("uUlLfF") if not tok.lower().startswith("0x") else tok.rstrip("uUlL")
    return float(int(tok, 16)) if tok.lower().startswith("0x") else float(tok)


def c_numbers(text: str) -> list[tuple[int, float]]:
    """(line, value) of every numeric literal (and literal * literal, literal << literal) in C or a
    template, comments and strings removed (line numbers kept)."""
    code = _C_NOISE.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)
    out = []
    for i, line in enumerate(code.splitlines(), 1):
        out += [(i, _c_value(m.group(1))) for m in _C_TOKEN.finditer(line)]
        for m in _C_PRODUCT.finditer(line):
            a, b = _c_value(m.group(1)), _c_value(m.group(3))
            if m.group(2) == "*" or (a.is_integer() and 0 <= b <= 62):
                out.append((i, a * b if m.group(2) == "*" else float(int(a) << int(b))))
    return out


def findings(rel: str, text: str, act: Actuator) -> list[str]:
    """'file:line: value (what)' for each of the actuator's numbers in one file's code."""
    nums = python_numbers(text) if rel.endswith(".py") else c_numbers(text)
    out = []
    for line, v in nums:
        for target, what in forbidden(act).items():
            if same(v, target) and (rel, target) not in ALLOWED:
                out.append(f"{rel}:{line}: {v:g} ({what})")
    by_line: dict[int, list[float]] = {}
    for line, v in nums:
        by_line.setdefault(line, []).append(v)
    for group, what in groups(act).items():
        for line, vs in by_line.items():
            if all(any(same(v, g) for v in vs) for g in group):
                out.append(f"{rel}:{line}: {', '.join(f'{g:g}' for g in group)} ({what})")
    return out


def scanned_files() -> list[tuple[str, Path]]:
    """(repository-relative path, path) of the Python, C and template files scanned."""
    out = []
    for top in SCANNED:
        for p in sorted((REPO / top).rglob("*")):
            rel = p.relative_to(REPO).as_posix()
            if p.suffix in (".py", ".c", ".h", ".j2") and not rel.startswith(EXEMPT):
                out.append((rel, p))
    return out


def test_no_actuator_number_outside_the_description():
    """Every scanned file is free of the paper's actuator numbers (except the ALLOWED entries)."""
    act = default_actuator()
    files = scanned_files()
    assert len(files) > 100, "the scan found too few files (paths moved?)"
    found = [f for rel, p in files for f in findings(rel, p.read_text(encoding="utf-8"), act)]
    assert not found, "actuator numbers outside the description:\n" + "\n".join(found)


def test_allow_list_is_not_stale():
    """Each ALLOWED entry still names a literal that is there (an unused entry is removed)."""
    act = default_actuator()
    for rel, value in ALLOWED:
        text = (REPO / rel).read_text(encoding="utf-8")
        nums = python_numbers(text) if rel.endswith(".py") else c_numbers(text)
        assert value in forbidden(act), (rel, value)
        assert any(same(v, value) for _, v in nums), f"{rel}: no {value:g} any more; drop it from ALLOWED"


@pytest.mark.parametrize(
    "rel, text, hit",
    [
        ("seagen/x.py", "POT_MAX = 4095\n", True),
        ("seagen/x.py", "TRAVEL = 20.0 / (380 * 12)\n", True),
        ("seagen/x.py", "N = 2**12\n", True),
        ("seagen/x.py", "k = -0.0031\n", True),
        ("seagen/x.py", "ANGLES = np.linspace(7.0, 25.0, 10)\n", True),
        ("seagen/x.py", "TARGETS = (5.0, 10.0, 15.0)\n", True),
        ("seagen/x.py", "VREF_MV = 3300.0\n", True),
        ("seagen/x.py", 'P = {"pot_voltage_drop": {"counts_per_unit_current": (20.0, 400.0)}}\n', True),
        ("seagen/x.py", 'R = {"gain": (80.0, 200.0), "tau": (0.04, 0.12)}\n', True),
        ("seagen/x.py", "TRUTH = (60.0, 200.0)\n", True),
        ("c_runtime/x.h", "#define SEA_POT_MAX 4095\n", True),
        ("c_runtime/x.h", "#define Q 73584u\n", True),
        ("templates/x.c.j2", "x = 1 << 12;\n", True),
        ("seagen/x.py", "X = 40950  # 4095 in a comment\n", False),
        ("seagen/x.py", 'S = "4095"\n"""4.2 N/mm in a docstring"""\n', False),
        ("seagen/x.py", "X = 4095.5 + 14.2 + 0.38\n", False),
        ("c_runtime/x.h", "/* 4095 */ int x = 4095000; /* 12000 mV */\n", False),
        ("seagen/x.py", "LIMIT = 7.0\nTOP = 25.0\n", False),
        ("seagen/x.py", "LO = 60.0\nHI = 200.0\n", False),
    ],
)
def test_scanner_catches_a_re_added_number(rel, text, hit):
    """The scan is token level: the actuator's numbers are found in code, not inside other numbers,
    comments or strings (a line with 7 and 25 is the contact range; each alone is not)."""
    assert bool(findings(rel, text, default_actuator())) == hit, findings(rel, text, default_actuator())
