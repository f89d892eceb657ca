"""Float surface fit (any degree) -> a fixed-point 2-D Horner program with per-coefficient Q formats, each
register's width proven over the calibrated box (or the fit refused naming the step and its failing bound)."""

from __future__ import annotations

import dataclasses

import numpy as np

from seagen.errors import UserError
from seagen.ir import QSF, FloatSF, QHorner, poly2
from seagen.quant.mlp import INT16_MAX, quantize_inputs
from seagen.quant.qformat import frac_for, widened
from seagen.runtime.fixed import rshift_rne

REG_LIMIT = 2**30  # registers keep a bit of headroom below int32
# Every product is shifted right by at least 16: the M4 kernel then takes the high word of one SMMUL/SMMLA
# and the M0+ kernel two 16x16 multiplies (sea_mulshr_s32). It costs ~0.001 N of bound on the defaults.
MIN_SHIFT = 16


@dataclasses.dataclass
class _Reg:
    """A register during planning: its real interval, format and error radius."""

    lo: float
    hi: float
    frac: int
    err: float

    @property
    def mag(self) -> float:
        """Largest magnitude of the interval."""
        return max(abs(self.lo), abs(self.hi))


def _mul_interval(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    p = (a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1])
    return min(p), max(p)


class _Planner:
    """Emits Horner ops while tracking intervals (sound), formats and error radii."""

    def __init__(self, boxes: list[tuple[float, float]], fracs: list[int]) -> None:
        self.boxes, self.fracs = boxes, fracs
        self.ops: list[QHorner] = []
        self.regs: dict[int, _Reg] = {}

    def load(self, dst: int, c: float) -> None:
        """r[dst] = constant c in its own Q format."""
        f = frac_for(abs(c), REG_LIMIT)
        q = int(np.rint(c * 2.0**f))
        if abs(q) > REG_LIMIT:
            raise UserError(
                f"surface fit: coefficient {c:.6g} is {abs(q):.3g} at Q{f}, the coarsest format seagen uses, "
                f"over the registers' proven limit 2^30"
            )
        self.ops.append(QHorner(dst, -1, -1, -1, q, 0, 0, f))
        self.regs[dst] = _Reg(c, c, f, abs(c - q * 2.0**-f))

    def fma(self, dst: int, var: int, src: int, add_reg: int = -1, c: float = 0.0) -> None:
        """r[dst] = floor(x[var] * r[src] / 2^shift) + (r[add_reg] aligned, or constant c), all in int32."""
        s, box, fx = self.regs[src], self.boxes[var], self.fracs[var]
        fp = fx + s.frac
        plo, phi = _mul_interval(box, (s.lo, s.hi))
        a = self.regs[add_reg] if add_reg >= 0 else _Reg(c, c, 0, 0.0)
        lo, hi = plo + a.lo, phi + a.hi
        f = min(frac_for(max(abs(lo), abs(hi)), REG_LIMIT), fp - MIN_SHIFT)
        for what, mag in (("product", max(abs(plo), abs(phi))), ("sum", max(abs(lo), abs(hi)))):
            if mag * 2.0**f >= 2**30:
                step = f"Horner step {len(self.ops) + 1} (r{dst} = {'ab'[var]} * r{src} + ...)"
                reach = f"{mag:.4g} over the calibrated box, {mag * 2.0**f:.4g} at Q{f}"
                raise UserError(
                    f"surface fit: {step}: its {what} reaches {reach}, over the int32 registers' proven "
                    "limit 2^30 (a lower degree or smaller coefficients or ranges)"
                )
        if add_reg >= 0:
            align, coef_q, aerr = f - a.frac, 0, a.err + (2.0**-f if f < a.frac else 0.0)
        else:
            coef_q = int(np.rint(c * 2.0**f))
            align, aerr = 0, abs(c - coef_q * 2.0**-f)
        xmag = max(abs(box[0]), abs(box[1]))
        floor_err = 2.0**-f if fp > f else 0.0  # a floor shift loses less than one LSB of the result
        err = xmag * s.err + s.mag * 2.0 ** -(fx + 1) + s.err * 2.0 ** -(fx + 1) + aerr + floor_err
        self.ops.append(QHorner(dst, var, src, add_reg, coef_q, align, fp - f, f))
        self.regs[dst] = _Reg(lo - err, hi + err, f, err)


def quantize_sf(model: FloatSF) -> QSF:
    """Plan f(a, b) = sum_i a^i P_i(b), each P_i by Horner in b, then Horner in a."""
    inputs = quantize_inputs(model)  # type: ignore[arg-type]
    boxes = [widened(s.lo, s.hi) for s in model.inputs]
    coef = {tuple(p): c for p, c in zip(model.powers, model.coef, strict=True)}
    deg = max(i + j for i, j in coef)
    pl = _Planner(boxes, [q.frac for q in inputs])
    for i in range(deg + 1):  # register i holds P_i(b)
        top = deg - i
        pl.load(i, coef.get((i, top), 0.0))
        for j in range(top - 1, -1, -1):
            pl.fma(i, 1, i, c=coef.get((i, j), 0.0))
    acc = deg
    for i in range(deg - 1, -1, -1):
        pl.fma(acc, 0, acc, add_reg=i)
    final = pl.regs[acc]
    out_frac = min(frac_for(final.mag, INT16_MAX), final.frac)
    shift = final.frac - out_frac
    top = int(np.ceil(final.mag * 2.0**final.frac))
    while int(rshift_rne(top, shift)) > INT16_MAX:  # frac_for stops at MIN_FRAC: go on until it fits int16
        out_frac -= 1
        shift += 1
    bound = final.err + 2.0 ** -(out_frac + 1)
    return QSF(
        inputs,
        model.output,
        out_frac,
        horner=tuple(pl.ops),
        out_shift=shift,
        n_regs=deg + 1,
        task=model.task,
        error_bound=bound,
    )


def float_sf(model: FloatSF, x: np.ndarray) -> np.ndarray:
    """The float polynomial on physical-unit inputs (N, 2)."""
    x = np.asarray(x, dtype=float)
    return poly2(model.powers, model.coef, x[:, 0], x[:, 1])
