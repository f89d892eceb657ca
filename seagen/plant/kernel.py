"""The Plant's motion compiled (numba): every batch element stepped on its own, its states at every step.

A twin of `Plant.step` for the plant as `sim.py` writes it (its force laws not overridden): the same
operations in the same order, element by element. The transcendental functions (arccos of the linkage
angle, exp of Stribeck friction) come from the C library both here and in `Plant` (`seagen.fmath`), but
the compiled loop may order a few operations differently, so the two are compared to rounding
(`tests/test_plant_kernel.py`). Each element depends only on its
own inputs, so a batch gives every element's numbers alone, whatever shares it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from seagen import fmath
from seagen.plant.sim import Plant

# effect parameters the kernel reads, in its order: (effect, parameter)
PARAMS = (
    ("actuator_friction", "force_n"),
    ("actuator_friction", "reverse_ratio"),
    ("linkage_friction", "c0_n"),
    ("linkage_friction", "c1_n"),
    ("linkage_friction", "c2_n"),
    ("viscous_friction", "b_n_s_per_mm"),
    ("stribeck_friction", "extra_static_n"),
    ("stribeck_friction", "v_s_mm_s"),
    ("series_compliance", "k_n_per_mm"),
    ("series_compliance", "beta_mm_per_n2"),
    ("backlash", "half_width_mm"),
    ("spring_preload", "force_n"),
    ("spring_nonlinearity", "k3_n_per_mm3"),
    # the term library's force-side effects (config.TERMS), from index 13
    ("lead_error", "amplitude_mm"),
    ("lead_error", "period_mm"),
    ("lead_error", "phase_rad"),
    ("cogging", "force_n"),
    ("cogging", "period_mm"),
    ("cogging", "phase_rad"),
    ("spring_drift", "share"),
    ("spring_drift", "time_constant_s"),
    ("rate_friction", "extra_n"),
    ("rate_friction", "v_c_mm_s"),
    ("rate_friction", "time_constant_s"),
    ("bristle_friction", "force_n"),
    ("bristle_friction", "x0_mm"),
    ("spring_hysteresis", "k_n_per_mm"),
    ("spring_hysteresis", "half_width_mm"),
    ("spring_poly", "k2_n_per_mm2"),
    ("spring_poly", "k3_n_per_mm3"),
    ("drive_saturation", "limit_v"),
    ("breakaway_friction", "extra_n"),
    ("breakaway_friction", "v_s_mm_s"),
    ("breakaway_friction", "time_constant_s"),
    ("breakaway_friction", "shape"),
    ("spring_bouc_wen", "force_n"),
    ("spring_bouc_wen", "width_mm"),
    ("spring_bouc_wen", "shape"),
    ("load_friction", "mu"),
    ("position_friction", "extra_n"),
    ("position_friction", "center_mm"),
    ("position_friction", "width_mm"),
    ("position_friction", "shape"),
    ("spring_knee", "dk_n_per_mm"),
    ("spring_knee", "onset_mm"),
    ("drive_gain_drift", "share"),
    ("drive_gain_drift", "time_constant_s"),
    ("current_limit", "limit_share"),
)
FLAGS = (
    "actuator_friction",
    "linkage_friction",
    "viscous_friction",
    "stribeck_friction",
    "series_compliance",
    "backlash",
    "spring_preload",
    "spring_nonlinearity",
    "lead_error",
    "cogging",
    "spring_drift",
    "rate_friction",
    "bristle_friction",
    "spring_hysteresis",
    "spring_poly",
    "drive_saturation",
    "breakaway_friction",
    "spring_bouc_wen",
    "load_friction",
    "position_friction",
    "spring_knee",
    "drive_gain_drift",
    "current_limit",
)
SENSOR_SIDE = (
    "pot_voltage_drop",
    "transport_delay",
    "load_cell_offset",
    "pot_noise",
    "learned_residual",
    "cell_drift",
    "cell_lag",
    "cell_quantisation",
    "cell_saturation",
    "pot_lag",
    "pot_hysteresis",
    "pot_quantisation",
    "pot_drift",
    "pot_saturation",
    "pot_reading_lag",
    "cell_soft_saturation",
    "cell_hysteresis",
    "cell_gain_drift",
    "pot_ripple",
)


@dataclass
class Trajectory:
    """States after k steps, k = 0..K, per element: shape (n_elements, K + 1)."""

    motor_mm: np.ndarray
    shaft_mm: np.ndarray
    force_n: np.ndarray  # structure force on the shaft (before any transport delay)
    current: np.ndarray | None = None  # recorded when asked for (`signals`)
    v_shaft: np.ndarray | None = None


def available(plant: Plant) -> bool:
    """Whether the kernel can step this plant: its force laws are `Plant`'s own and the sensor-side
    effects (which the kernel does not model) are off."""
    laws = (
        "step",
        "spring_force",
        "_spring_slope",
        "structure_force",
        "friction_limits",
        "_move_shaft",
        "_move_nut",
        "_terms",
        "_lead",
        "_drift",
    )
    if any(getattr(type(plant), m) is not getattr(Plant, m) for m in laws):
        return False
    return not any(plant.cfg.on(e) for e in SENSOR_SIDE if e != "pot_noise")


def run(plant: Plant, volts: np.ndarray, signals: int = 5) -> Trajectory:
    """Step a fresh plant (all states zero) with command volts (n_elements, K): its states at every step,
    the first `signals` of Trajectory's (3: positions and force; 4: and the current; 5: all)."""
    cfg, geo, m = plant.cfg, plant.geo, plant.motor
    n = plant.nut_mm.size
    par = np.empty((len(PARAMS), n))
    for i, (e, p) in enumerate(PARAMS):
        par[i] = getattr(cfg.effect(e), p) if cfg.on(e) else 0.0
    flags = np.array([cfg.on(e) for e in FLAGS], dtype=np.bool_)
    consts = np.array(
        [
            cfg.dt_s,
            m.supply_v,
            m.stall_force_n,
            plant.v_max,
            min(cfg.dt_s / m.time_constant_s, 1.0),
            plant.k_spring,
            plant.k_stop,
            plant.k_rigid,
            float(fmath.cos(np.radians(geo.home_deg))),
            geo.cb_mm,
            geo.split_deg,
            geo.angle_max_deg,
        ]
    )
    k = volts.shape[1]
    out = np.empty((signals, n, k + 1))
    _step_all(
        np.ascontiguousarray(volts, dtype=float), np.asarray(plant.y_contact, float), par, flags, consts, out
    )
    return Trajectory(*out)


def _spring(d, k_spring, k_stop, nl, k3, pre, f0):
    """Plant.spring_force of one element."""
    f = k_spring * d if d >= 0 else k_stop * d
    if nl:
        x = d if d > 0.0 else 0.0
        f = f + k3 * (x * x * x)
    if pre:
        f = f + f0
    return f


def _spring_slope(d, k_spring, k_stop, nl, k3):
    """Plant._spring_slope of one element."""
    s = k_spring if d >= 0 else k_stop
    if nl:
        x = d if d > 0.0 else 0.0
        s = s + 3.0 * k3 * (x * x)
    return s


def _spring_x(d, k_spring, k_stop, nl, k3, pre, f0, tx):
    """Plant.spring_force of one element with the term library's spring terms: tx = (drift flag, drift
    factor now, poly flag, k2, k3, hysteresis flag, k_h, w, h, Bouc-Wen flag, its h times its state z, knee
    flag, its dk, its onset)."""
    f = k_spring * d if d >= 0 else k_stop * d
    if tx[0] and d >= 0:
        f = f + k_spring * tx[1] * d
    if tx[2]:
        dp = d if d > 0.0 else 0.0
        f = f + (tx[3] + tx[4] * dp) * (dp * dp)
    if tx[11]:
        x = d - tx[13]
        f = f + tx[12] * (x if x > 0.0 else 0.0)
    if tx[5]:
        h = min(max(tx[8], d - tx[7]), d + tx[7])
        f = f + tx[6] * (d - h)
    if tx[9]:
        f = f + (tx[10] if d >= 0 else 0.0)
    if nl:
        x = d if d > 0.0 else 0.0
        f = f + k3 * (x * x * x)
    if pre:
        f = f + f0
    return f


def _spring_slope_x(d, k_spring, k_stop, nl, k3, tx):
    """Plant._spring_slope of one element with the term library's spring terms (tx as in _spring_x)."""
    s = k_spring if d >= 0 else k_stop
    if tx[0] and d >= 0:
        s = s + k_spring * tx[1]
    if tx[2]:
        dp = d if d > 0.0 else 0.0
        s = s + (2 * tx[3] + 3 * tx[4] * dp) * dp
    if tx[11]:
        s = s + (tx[12] if d > tx[13] else 0.0)
    if tx[5] and abs(d - tx[8]) > tx[7]:
        s = s + tx[6]
    if nl:
        x = d if d > 0.0 else 0.0
        s = s + 3.0 * k3 * (x * x)
    return s


def _structure(y, yc, sc, k_rigid, a, beta):
    """Plant.structure_force of one element: (force, slope); a = 1 / k of the compliance."""
    d = y - yc
    if d < 0.0:
        d = 0.0
    inside = y > yc
    if not sc:
        return k_rigid * d, (k_rigid if inside else 0.0)
    if beta > 0:
        root = math.sqrt(a * a + 4.0 * beta * d)
        return (root - a) / (2.0 * beta), (1.0 / root if inside else 0.0)
    return d / a, (1.0 / a if inside else 0.0)


def _loop(volts, y_contact, par, flags, consts, out):
    """Every element through every step (see Plant.step, _move_nut, _move_shaft, _solve)."""
    dt, supply, stall, v_max, alpha = consts[0], consts[1], consts[2], consts[3], consts[4]
    k_spring, k_stop, k_rigid, cos_home, cb, split, amax = (
        consts[5],
        consts[6],
        consts[7],
        consts[8],
        consts[9],
        consts[10],
        consts[11],
    )
    act, link, visc, strib, sc, bl, pre, nl = (
        flags[0],
        flags[1],
        flags[2],
        flags[3],
        flags[4],
        flags[5],
        flags[6],
        flags[7],
    )
    lead, cog, drift, rate, bristle, hyst, poly = (
        flags[8],
        flags[9],
        flags[10],
        flags[11],
        flags[12],
        flags[13],
        flags[14],
    )
    brk, bw = flags[16], flags[17]
    lfr, pfr, knee, gdr, clim = flags[18], flags[19], flags[20], flags[21], flags[22]
    terms = lead or cog or drift or rate or bristle or hyst or poly or brk or bw or knee
    rad2deg = 180.0 / math.pi
    n, k_max = volts.shape
    n_sig = out.shape[0]
    for i in range(n):
        fc, rr, c0, c1, c2 = par[0, i], par[1, i], par[2, i], par[3, i], par[4, i]
        bv, s_extra, s_vs, kc, beta = par[5, i], par[6, i], par[7, i], par[8, i], par[9, i]
        half, f0, k3 = par[10, i], par[11, i], par[12, i]
        la, lp, lph, ca, cp, cph = par[13, i], par[14, i], par[15, i], par[16, i], par[17, i], par[18, i]
        ds, dtau, ra, rvc, rtau, ba, bx0 = (
            par[19, i],
            par[20, i],
            par[21, i],
            par[22, i],
            par[23, i],
            par[24, i],
            par[25, i],
        )
        hk, hw, pk2, pk3, vsat = par[26, i], par[27, i], par[28, i], par[29, i], par[30, i]
        sat = flags[15]
        kx, kvs, ktau, kdl = par[31, i], par[32, i], par[33, i], par[34, i]
        bh, bwd, bn = par[35, i], par[36, i], par[37, i]
        mu, pa, pc, pw, pn = par[38, i], par[39, i], par[40, i], par[41, i], par[42, i]
        kdk, kd0, gs, gtau, climit = par[43, i], par[44, i], par[45, i], par[46, i], par[47, i]
        hstate = wstate = travel = vsign = t = 0.0
        kstate = bz = bd = 0.0
        ralpha = min(dt / rtau, 1.0) if rate else 0.0
        kalpha = min(dt / ktau, 1.0) if brk else 0.0
        tx = (drift, 0.0, poly, pk2, pk3, hyst, hk, hw, hstate, bw, bh * bz, knee, kdk, kd0)
        yc = y_contact[i]
        a = 1.0 / kc if sc else 0.0
        b = bv / dt if visc else 0.0
        y_link, f_link = np.nan, 0.0  # the linkage friction at the last shaft position it was computed for
        ratio = rr if act else 1.0
        motor = v_motor = nut = shaft = v_shaft = current = force = 0.0
        for j in range(n_sig):
            out[j, i, 0] = 0.0
        for k in range(k_max):
            v = volts[i, k]
            v = min(max(v, -supply), supply)
            if gdr:
                v = v * (1.0 + gs * (1.0 - math.exp(-t / gtau)))
            if sat:
                v = min(max(v, -vsat), vsat)
            if clim:
                back = v_motor / v_max
                v = min(max(v, supply * (back - climit)), supply * (back + climit))
            if terms:
                dfac = ds * (1.0 - math.exp(-t / dtau)) if drift else 0.0
                tx = (drift, dfac, poly, pk2, pk3, hyst, hk, hw, hstate, bw, bh * bz, knee, kdk, kd0)
                load = _spring_x(nut - shaft, k_spring, k_stop, nl, k3, pre, f0, tx)
                if cog:
                    load = load + ca * math.cos(2 * math.pi * motor / cp + cph)
            else:
                load = _spring(nut - shaft, k_spring, k_stop, nl, k3, pre, f0)
            v_target = v_max * (v / supply - load / stall)
            v_motor = v_motor + (v_target - v_motor) * alpha
            current = v / supply - v_motor / v_max
            motor = motor + v_motor * dt
            mlead = motor + la * math.cos(2 * math.pi * motor / lp + lph) if lead else motor
            nut = min(max(nut, mlead - half), mlead + half) if bl else mlead
            # the shaft: stick inside the friction band, else slide to its edge
            y0 = shaft
            fwd = fc if act else 0.0
            if link:
                ym = min(y0, yc)
                if ym != y_link:  # the angle stays put in contact: computed once
                    c = cos_home - ym / cb
                    c = min(max(c, -1.0), 1.0)
                    angle = math.acos(c) * rad2deg
                    x = (angle - split) / (amax - split)
                    y_link, f_link = ym, max(fwd + c0 + c1 * x + c2 * x * x, 0.0)
                fwd = f_link
            rev = fwd * ratio
            if strib:
                q = v_shaft / s_vs
                boost = s_extra * math.exp(-(q * q))
                fwd = fwd + boost
                rev = rev + boost * (1.0 if rev > 0 else 0.0)
            if rate:
                boost = ra * math.exp(-wstate / rvc)
                fwd, rev = fwd + boost, rev + boost
            if brk:
                boost = kx / (1.0 + (kstate / kvs) ** kdl)
                fwd, rev = fwd + boost, rev + boost
            if bristle:
                band = ba * (1.0 - math.exp(-travel / bx0))
                fwd, rev = fwd + band, rev + band
            if lfr:  # the structure's force at the last step
                band = mu * abs(force)
                fwd, rev = fwd + band, rev + band
            if pfr:
                band = pa * math.exp(-(abs((y0 - pc) / pw) ** pn))
                fwd, rev = fwd + band, rev + band
            d0 = nut - y0
            fl, sl = _structure(y0, yc, sc, k_rigid, a, beta)
            if terms:
                n0 = _spring_x(d0, k_spring, k_stop, nl, k3, pre, f0, tx) - fl
                s0 = -_spring_slope_x(d0, k_spring, k_stop, nl, k3, tx) - sl
            else:
                n0 = _spring(d0, k_spring, k_stop, nl, k3, pre, f0) - fl
                s0 = -_spring_slope(d0, k_spring, k_stop, nl, k3) - sl
            target = fwd if n0 > fwd else (-rev if n0 < -rev else n0)
            y = y0
            if target != n0:  # safeguarded Newton (Plant._solve)
                f, s = n0, s0
                span = abs(f - target) / k_spring
                if f > target:
                    lo, hi = y0, y0 + span
                else:
                    lo, hi = y0 - span, y0
                ya = y0
                last = np.inf
                done = False
                for _ in range(50):
                    r = f - b * (ya - y0) - target
                    if r > 0:
                        lo = ya
                    else:
                        hi = ya
                    st = r / (s - b)
                    y_new = ya - st
                    if not ((y_new >= lo) and (y_new <= hi) and (2 * abs(st) <= last)):
                        y_new = 0.5 * (lo + hi)
                    last = abs(y_new - ya)
                    done = last < 1e-9
                    ya = y_new
                    if done:
                        break
                    d = nut - ya
                    fl, sl = _structure(ya, yc, sc, k_rigid, a, beta)
                    if terms:
                        f = _spring_x(d, k_spring, k_stop, nl, k3, pre, f0, tx) - fl
                        s = -_spring_slope_x(d, k_spring, k_stop, nl, k3, tx) - sl
                    else:
                        f = _spring(d, k_spring, k_stop, nl, k3, pre, f0) - fl
                        s = -_spring_slope(d, k_spring, k_stop, nl, k3) - sl
                y = ya
            v_shaft = (y - y0) / dt
            shaft = y
            if hyst:  # the states of the term library's effects (Plant._terms)
                dd = nut - shaft
                hstate = min(max(hstate, dd - hw), dd + hw)
            if rate:
                wstate = wstate + (abs(v_shaft) - wstate) * ralpha
            if brk:
                kstate = kstate + (abs(v_shaft) - kstate) * kalpha
            if bw:
                dd = (nut - shaft) - bd
                sg = 1.0 if dd > 0 else (-1.0 if dd < 0 else 0.0)
                sz = 1.0 if bz > 0 else (-1.0 if bz < 0 else 0.0)
                bz = bz + min(abs(dd) / bwd, 1.0) * sg * (1.0 - sg * sz * abs(bz) ** bn)
                bz = min(max(bz, -1.0), 1.0)
                bd = nut - shaft
            if bristle:
                dy = shaft - y0
                sg = 1.0 if dy > 0 else (-1.0 if dy < 0 else 0.0)
                travel = 0.0 if sg != 0 and sg != vsign and vsign != 0 else travel + abs(dy)
                if sg != 0:
                    vsign = sg
            t = t + dt
            force = _structure(shaft, yc, sc, k_rigid, a, beta)[0]
            out[0, i, k + 1] = motor
            out[1, i, k + 1] = shaft
            out[2, i, k + 1] = force
            if n_sig > 3:
                out[3, i, k + 1] = current
            if n_sig > 4:
                out[4, i, k + 1] = v_shaft


def _drop(current, of_set, kappa, alpha, out):
    """The pot-drop filter of every set element (see replay.simulate), after every step."""
    for e in range(of_set.size):
        m, d = of_set[e], 0.0
        for k in range(1, current.shape[1]):
            d += (kappa[e] * abs(current[m, k]) - d) * alpha[e]
            out[e, k] = d


def pot_drop(current: np.ndarray, of_set: np.ndarray, kappa: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The pot's voltage drop after every step (n_sets_elements, K + 1) of the elements of_set of a
    trajectory's current: drop += (kappa |current| - drop) alpha each step, from zero."""
    out = np.zeros((of_set.size, current.shape[1]))
    _drop_all(current, np.asarray(of_set, np.int64), np.asarray(kappa, float), np.asarray(alpha, float), out)
    return out


def _lag(x, of_set, alpha, out):
    """A first-order lag of every set element's trajectory row (see lagged), from the row's first value."""
    for e in range(of_set.size):
        m = of_set[e]
        c = x[m, 0]
        out[e, 0] = c
        for k in range(1, x.shape[1]):
            c = x[m, k] if alpha[e] >= 1.0 else c + (x[m, k] - c) * alpha[e]
            out[e, k] = c


def lagged(x: np.ndarray, of_set: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """x's rows of_set (a trajectory, (n_elements, K + 1)) behind a first-order lag each: c += (x - c) alpha
    per step from the row's first value (sim.lag_step: x itself when alpha >= 1); (of_set.size, K + 1)."""
    out = np.zeros((of_set.size, x.shape[1]))
    _lag_all(x, np.asarray(of_set, np.int64), np.asarray(alpha, float), out)
    return out


# compiled on first use, cached beside the module (or in numba's user cache when that is read-only)
# (numpy's error model: a division by zero gives inf or nan as in Plant, never an exception)
_drop_all = numba.njit(_drop, cache=True, error_model="numpy")
_lag_all = numba.njit(_lag, cache=True, error_model="numpy")
_spring = numba.njit(_spring, cache=True, error_model="numpy")
_spring_slope = numba.njit(_spring_slope, cache=True, error_model="numpy")
_spring_x = numba.njit(_spring_x, cache=True, error_model="numpy")
_spring_slope_x = numba.njit(_spring_slope_x, cache=True, error_model="numpy")
_structure = numba.njit(_structure, cache=True, error_model="numpy")
_step_all = numba.njit(_loop, cache=True, error_model="numpy")
