"""The SEA stepped in time: motor, backlash, spring, friction on the shaft, structure, sensors (batched)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from seagen import fmath
from seagen.geometry import geometry
from seagen.plant.config import PlantConfig

# Stiffnesses of the plant relative to the description's spring (exact for the paper's 4.2 N/mm: 400, 5000):
STOP_PER_SPRING = 95.23809523809524  # hard stop when the nut pulls the shaft back (negative compression)
RIGID_PER_SPRING = 1190.4761904761904  # structure stiffness when series_compliance is off


def pick(x, idx: np.ndarray | None):
    """x[idx] for a per-element array (a parameter or state over the batch); a scalar, or any x when idx
    is None, passes through unchanged."""
    if idx is None or not isinstance(x, np.ndarray) or x.ndim == 0:
        return x
    return x[idx]


def _scalar(x) -> bool:
    """Whether a parameter is one value for the whole batch (a number or a 0-d array)."""
    return not isinstance(x, np.ndarray) or x.ndim == 0


@dataclass
class Sensors:
    """One sample of every signal, each an array over the batch of trials."""

    enc: np.ndarray  # encoder counts (int64)
    pot: np.ndarray  # pot ADC counts (int64, 0..the description's ADC maximum)
    load_cell_n: np.ndarray  # measured tip force (N)
    force_n: np.ndarray  # reference force at the SEA output shaft: load cell / R_l(contact angle)
    true_force_n: np.ndarray  # noise-free force the linkage carries at the shaft (N)
    angle_deg: np.ndarray  # true linkage angle
    compression_mm: np.ndarray  # true spring compression
    motor_current: np.ndarray  # motor current, normalised to stall at the supply voltage


def learned_basis(inputs: list[str], scales: list[float], values: dict[str, np.ndarray]) -> np.ndarray:
    """Basis of a learned residual, shape (..., 1 + 5 len(inputs)): 1, then per input u = x / scale:
    u, u^2, u^3, tanh(4 u) (a smoothed sign) and exp(-4 u^2) (a bump at zero)."""
    shape = np.broadcast_shapes(*(np.shape(values[k]) for k in inputs)) if inputs else ()
    cols = [np.ones(shape)]
    for k, sc in zip(inputs, scales, strict=True):
        u = np.broadcast_to(np.asarray(values[k], float), shape) / sc
        cols += [u, u * u, u * u * u, fmath.tanh(4 * u), fmath.exp(-4 * u * u)]
    return np.stack(cols, axis=-1)


def learned_correction(eff, values: dict[str, np.ndarray]) -> np.ndarray:
    """The learned residual's value (in its channel's unit) for plant signals `values` (LEARNED_INPUTS)."""
    return learned_basis(eff.inputs, eff.scales, values) @ np.asarray(eff.coef, float)


def cell_terms(e, load_cell: np.ndarray, t) -> np.ndarray:
    """The term library's load-cell distortions (cell_distort) of the effects e that are on, at time t."""
    cd, cs, cq, ss = e.cell_drift, e.cell_saturation, e.cell_quantisation, e.cell_soft_saturation
    cg = e.cell_gain_drift
    return cell_distort(
        load_cell,
        t,
        (cd.offset_n, cd.time_constant_s) if cd.enabled else None,
        cs.limit_n if cs.enabled else None,
        cq.step_n if cq.enabled else None,
        (ss.limit_n, ss.sharpness) if ss.enabled else None,
        (cg.share, cg.time_constant_s) if cg.enabled else None,
    )


def cell_distort(
    load_cell: np.ndarray, t, drift=None, limit=None, step=None, soft=None, gain=None
) -> np.ndarray:
    """A load-cell reading at time t (s into the trial) times a drifting sensitivity 1 + s (1 - exp(-t /
    tau)) (gain = (s, tau)), with a drifting zero A (1 - exp(-t / tau)) (drift = (A, tau)), saturated at
    +-limit, through a knee (soft = (L, n): soft_clip), then read in steps (each None when off; scalars or
    arrays like the reading; a step of 0 reads as is)."""
    if gain is not None:
        tau = np.asarray(gain[1], float)
        load_cell = load_cell * (1.0 + gain[0] * (1.0 - fmath.exp(-np.asarray(t, float) / tau)))
    if drift is not None:
        tau = np.asarray(drift[1], float)
        load_cell = load_cell + drift[0] * (1.0 - fmath.exp(-np.asarray(t, float) / tau))
    if limit is not None:
        load_cell = np.minimum(np.maximum(load_cell, -limit), limit)
    if soft is not None:
        load_cell = soft_clip(load_cell, soft[0], soft[1])
    if step is not None:
        q = np.asarray(step, float)
        safe = np.where(q > 0, q, 1.0)
        load_cell = np.where(q > 0, safe * np.rint(load_cell / safe), load_cell)
    return load_cell


def pot_ripple(c: np.ndarray, amplitude, period, phase) -> np.ndarray:
    """pot_ripple's part of the pot's reading at angle reading c (counts): A cos(2 pi c / P + phi)."""
    return amplitude * fmath.cos(2 * np.pi * c / period + phase)


def lag_step(state: np.ndarray, x: np.ndarray, alpha) -> np.ndarray:
    """One step of a first-order lag: x itself when alpha >= 1 (no lag), else state + (x - state) alpha."""
    return np.where(np.asarray(alpha) >= 1.0, x, state + (x - state) * alpha)


def soft_clip(x: np.ndarray, limit, sharpness) -> np.ndarray:
    """A saturation with a knee (cell_soft_saturation): x / (1 + |x / L|^n)^(1 / n) (n -> inf: the clip)."""
    n = np.asarray(sharpness, float)
    return x / np.power(1.0 + np.power(np.abs(x / np.asarray(limit, float)), n), 1.0 / n)


def hysteresis_step(z: np.ndarray, dx: np.ndarray, width, shape) -> np.ndarray:
    """One reading of cell_hysteresis's state (Bouc-Wen type): z += (dx / w) (1 - sign(dx) sign(z) |z|^n),
    the step |dx| / w at most 1, z kept in [-1, 1]."""
    s = np.minimum(np.abs(dx) / np.asarray(width, float), 1.0) * np.sign(dx)
    z = z + s * (1.0 - np.sign(dx) * np.sign(z) * np.power(np.abs(z), np.asarray(shape, float)))
    return np.minimum(np.maximum(z, -1.0), 1.0)


def reading_alpha(dt, tau) -> np.ndarray:
    """Weight of a first-order lag of time constant tau updated by one reading dt after the last
    (pot_reading_lag): 1 - exp(-dt / tau); 1 (no lag) for tau = 0."""
    tau = np.asarray(tau, float)
    safe = np.where(tau > 0, tau, 1.0)
    return np.where(tau > 0, 1.0 - fmath.exp(-np.asarray(dt, float) / safe), 1.0)


def pot_distort(pot: np.ndarray, t, drift=None, limit=None) -> np.ndarray:
    """A pot reading at time t (s into the trial) with a drifting zero A (1 - exp(-t / tau)) counts (drift =
    (A, tau)), then clamped above at limit counts (each None when off)."""
    if drift is not None:
        pot = pot + drift[0] * (1.0 - fmath.exp(-np.asarray(t, float) / np.asarray(drift[1], float)))
    if limit is not None:
        pot = np.minimum(pot, limit)
    return pot


class Plant:
    """A batch of simulated SEAs, one per contact angle, stepped at cfg.dt_s; deterministic for a seed.
    Every actuator number comes from cfg.actuator (its Geometry is `self.geo`)."""

    def __init__(self, cfg: PlantConfig, contact_deg: np.ndarray | float, seed: int = 0) -> None:
        self.cfg = cfg
        self.contact_deg = np.atleast_1d(np.asarray(contact_deg, dtype=float))
        n = self.contact_deg.size
        self.rng = np.random.default_rng(seed)
        self.geo = geo = geometry(cfg.actuator)
        self.k_spring = geo.spring_n_per_mm
        self.k_stop = geo.spring_n_per_mm * STOP_PER_SPRING
        self.k_rigid = geo.spring_n_per_mm * RIGID_PER_SPRING
        self.y_contact = geo.shaft_advance_mm(self.contact_deg)
        self.ratio = geo.linkage_ratio(self.contact_deg)
        self.motor_mm = np.zeros(n)  # motor position in nut millimetres (what the encoder sees)
        self.v_motor = np.zeros(n)  # mm/s at the nut
        self.nut_mm = np.zeros(n)  # nut advance u (after backlash)
        self.shaft_mm = np.zeros(n)  # output-shaft advance y
        self.v_shaft = np.zeros(n)
        self.current = np.zeros(n)
        self.pot_drop = np.zeros(n)
        self.t = 0.0
        self.motor = cfg.motor  # the description's
        self.v_max = self.motor.v_max_mm_s  # mm/s at the nut
        td = cfg.effects.transport_delay
        self._delay_n = int(round(td.delay_s / cfg.dt_s)) if td.enabled else 0
        self._history = np.zeros((self._delay_n + 1, n))
        # states of the term library's effects (config.TERMS): hysteresis play, speed state, travel since
        # the shaft's last reversal and its direction, the lagged load cell
        self._h, self._w, self._travel, self._vsign, self._cell = (np.zeros(n) for _ in range(5))
        self._pot_h: np.ndarray | None = None  # the pot's play state, from its first reading
        self._pot_l = self._pot_angle() if cfg.on("pot_lag") else np.zeros(n)
        # breakaway_friction's lagged speed; spring_bouc_wen's state and the compression it last saw
        self._wb, self._bz, self._bd = (np.zeros(n) for _ in range(3))
        # the pot's whole reading behind a lag and the time of its last reading (pot_reading_lag); the load
        # cell's hysteresis state and the tip force it last saw (cell_hysteresis); both from the first reading
        self._pot_r: np.ndarray | None = None
        self._t_read = 0.0
        self._cell_z: np.ndarray | None = None
        self._cell_tip = np.zeros(n)

    # --- force laws -------------------------------------------------------------------------------
    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """Spring force for compression d (with preload and nonlinearity when enabled); d is over the
        batch elements idx (all when None), per-element parameters are taken at idx."""
        e = self.cfg.effects
        f = np.where(d >= 0, self.k_spring * d, self.k_stop * d)
        if e.spring_drift.enabled:
            f = f + np.where(d >= 0, self.k_spring * self._drift(idx) * d, 0.0)
        if e.spring_poly.enabled:
            sp, dp = e.spring_poly, np.maximum(d, 0.0)
            f = f + (pick(sp.k2_n_per_mm2, idx) + pick(sp.k3_n_per_mm3, idx) * dp) * (dp * dp)
        if e.spring_knee.enabled:
            sk = e.spring_knee
            f = f + pick(sk.dk_n_per_mm, idx) * np.maximum(d - pick(sk.onset_mm, idx), 0.0)
        if e.spring_hysteresis.enabled:
            sh = e.spring_hysteresis
            w, h = pick(sh.half_width_mm, idx), pick(self._h, idx)
            f = f + pick(sh.k_n_per_mm, idx) * (d - np.minimum(np.maximum(h, d - w), d + w))
        if e.spring_bouc_wen.enabled:
            f = f + np.where(d >= 0, pick(e.spring_bouc_wen.force_n, idx) * pick(self._bz, idx), 0.0)
        if e.spring_nonlinearity.enabled:
            dp = np.maximum(d, 0.0)
            f = f + pick(e.spring_nonlinearity.k3_n_per_mm3, idx) * (dp * dp * dp)
        if e.spring_preload.enabled:
            f = f + pick(e.spring_preload.force_n, idx)
        return f

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """dF/dd of spring_force at compression d over the batch elements idx (all when None)."""
        e = self.cfg.effects
        s = np.where(d >= 0, self.k_spring, self.k_stop)
        if e.spring_drift.enabled:
            s = s + np.where(d >= 0, self.k_spring * self._drift(idx), 0.0)
        if e.spring_poly.enabled:
            sp, dp = e.spring_poly, np.maximum(d, 0.0)
            s = s + (2 * pick(sp.k2_n_per_mm2, idx) + 3 * pick(sp.k3_n_per_mm3, idx) * dp) * dp
        if e.spring_knee.enabled:
            sk = e.spring_knee
            s = s + np.where(d > pick(sk.onset_mm, idx), pick(sk.dk_n_per_mm, idx), 0.0)
        if e.spring_hysteresis.enabled:
            sh = e.spring_hysteresis
            w, h = pick(sh.half_width_mm, idx), pick(self._h, idx)
            s = s + np.where(np.abs(d - h) > w, pick(sh.k_n_per_mm, idx), 0.0)
        if e.spring_nonlinearity.enabled:
            dp = np.maximum(d, 0.0)
            s = s + 3 * pick(e.spring_nonlinearity.k3_n_per_mm3, idx) * (dp * dp)
        return s

    def _drift(self, idx: np.ndarray | None = None):
        """spring_drift's share of the stiffness gained by now: share (1 - exp(-t / tau))."""
        sd = self.cfg.effects.spring_drift
        tau = np.asarray(pick(sd.time_constant_s, idx), float)
        return pick(sd.share, idx) * (1.0 - fmath.exp(-self.t / tau))

    def structure_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Force the loaded linkage pushes back with, and its slope, for shaft advance y of the batch
        elements idx (all when None).

        The compliance parameters may be scalars or arrays over the batch (the discrepancy replay fits
        one parameter set per element): beta > 0 inverts d = F/k + beta F^2, beta = 0 is linear.
        Overrides must take per-element arrays at idx (`pick`) and treat each element on its own.
        """
        yc = pick(self.y_contact, idx)
        d = np.maximum(y - yc, 0.0)
        sc = self.cfg.effects.series_compliance
        if not sc.enabled:
            return self.k_rigid * d, np.where(y > yc, self.k_rigid, 0.0)
        inside = y > yc
        k, beta = sc.k_n_per_mm, sc.beta_mm_per_n2
        a = 1.0 / float(k) if _scalar(k) else 1.0 / np.asarray(pick(k, idx), float)
        if _scalar(beta):  # one law for every element (the usual case): the same values in fewer
            b1 = float(beta)  # operations (Python floats: no per-call array overhead)
            if b1 <= 0:
                return d / a, np.where(inside, 1.0 / a, 0.0)
            root = np.sqrt(a * a + 4 * b1 * d)
            return (root - a) / (2 * b1), np.where(inside, 1.0 / root, 0.0)
        b = np.asarray(pick(beta, idx), float)
        quad = b > 0
        bq = np.where(quad, b, 1.0)
        root = np.sqrt(a * a + 4 * bq * d)
        force = np.where(quad, (root - a) / (2 * bq), d / a)
        slope = np.where(quad, 1.0 / root, 1.0 / a)
        return force, np.where(inside, slope, 0.0)

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Coulomb friction on the shaft (forward, reverse) at this linkage angle, before speed terms."""
        e = self.cfg.effects
        fwd = np.zeros_like(angle_deg)
        if e.actuator_friction.enabled:
            fwd = fwd + e.actuator_friction.force_n
        if e.linkage_friction.enabled:
            lf = e.linkage_friction
            geo = self.geo
            x = (angle_deg - geo.split_deg) / (geo.angle_max_deg - geo.split_deg)
            fwd = np.maximum(fwd + lf.c0_n + lf.c1_n * x + lf.c2_n * x * x, 0.0)
        ratio = e.actuator_friction.reverse_ratio if e.actuator_friction.enabled else 1.0
        return fwd, fwd * ratio

    # --- stepping ---------------------------------------------------------------------------------
    def step(self, motor_v: np.ndarray | float) -> None:
        """Advance one internal step with motor command `motor_v` (V, clipped to the supply)."""
        cfg, dt = self.cfg, self.cfg.dt_s
        m = self.motor
        # np.clip's value, without its per-call overhead (the replay steps small batches many times)
        volts = np.minimum(np.maximum(np.asarray(motor_v, dtype=float), -m.supply_v), m.supply_v)
        if volts.shape != self.nut_mm.shape:
            volts = np.broadcast_to(volts, self.nut_mm.shape)
        if cfg.effects.drive_gain_drift.enabled:
            gd = cfg.effects.drive_gain_drift
            volts = volts * (
                1.0 + gd.share * (1.0 - fmath.exp(-self.t / np.asarray(gd.time_constant_s, float)))
            )
        if cfg.effects.drive_saturation.enabled:
            lim = cfg.effects.drive_saturation.limit_v
            volts = np.minimum(np.maximum(volts, -lim), lim)
        if cfg.effects.current_limit.enabled:  # |V / V_s - v / v_max| <= the limit's share of stall
            back, cl = self.v_motor / self.v_max, cfg.effects.current_limit.limit_share
            volts = np.minimum(np.maximum(volts, m.supply_v * (back - cl)), m.supply_v * (back + cl))
        load = self.spring_force(self.nut_mm - self.shaft_mm)
        if cfg.effects.cogging.enabled:
            cg = cfg.effects.cogging
            load = load + cg.force_n * fmath.cos(2 * np.pi * self.motor_mm / cg.period_mm + cg.phase_rad)
        v_target = self.v_max * (volts / m.supply_v - load / m.stall_force_n)
        self.v_motor = self.v_motor + (v_target - self.v_motor) * min(dt / m.time_constant_s, 1.0)
        self.current = m.current(volts, self.v_motor)
        self.motor_mm = self.motor_mm + self.v_motor * dt
        self._move_nut()
        y0 = self.shaft_mm
        self._move_shaft(dt)
        self._terms(y0, dt)
        pvd = cfg.effects.pot_voltage_drop
        if pvd.enabled:
            target = pvd.counts_per_unit_current * np.abs(self.current)
            self.pot_drop += (target - self.pot_drop) * np.minimum(dt / np.asarray(pvd.time_constant_s), 1.0)
        # a fresh array each step (a caller may hold the last shaft_force); no roll without a delay
        self._history = np.roll(self._history, 1, axis=0) if self._delay_n else np.empty_like(self._history)
        self._history[0] = self.structure_force(self.shaft_mm)[0]
        if cfg.effects.cell_lag.enabled:
            a = np.minimum(dt / np.asarray(cfg.effects.cell_lag.time_constant_s, float), 1.0)
            self._cell = lag_step(self._cell, self._history[self._delay_n], a)
        if cfg.effects.pot_lag.enabled:
            a = np.minimum(dt / np.asarray(cfg.effects.pot_lag.time_constant_s, float), 1.0)
            self._pot_l = lag_step(self._pot_l, self._pot_angle(), a)
        self.t += dt

    def _terms(self, y0: np.ndarray, dt: float) -> None:
        """After the shaft moved from y0: the states of the term library's effects (config.TERMS)."""
        e = self.cfg.effects
        if e.spring_hysteresis.enabled:
            d, w = self.nut_mm - self.shaft_mm, e.spring_hysteresis.half_width_mm
            self._h = np.minimum(np.maximum(self._h, d - w), d + w)
        if e.rate_friction.enabled:
            a = np.minimum(dt / np.asarray(e.rate_friction.time_constant_s, float), 1.0)
            self._w = self._w + (np.abs(self.v_shaft) - self._w) * a
        if e.breakaway_friction.enabled:
            a = np.minimum(dt / np.asarray(e.breakaway_friction.time_constant_s, float), 1.0)
            self._wb = self._wb + (np.abs(self.v_shaft) - self._wb) * a
        if e.spring_bouc_wen.enabled:
            sb, d = e.spring_bouc_wen, self.nut_mm - self.shaft_mm
            self._bz, self._bd = hysteresis_step(self._bz, d - self._bd, sb.width_mm, sb.shape), d
        if e.bristle_friction.enabled:
            dy = self.shaft_mm - y0
            sign = np.sign(dy)
            flip = (sign != 0) & (sign != self._vsign) & (self._vsign != 0)
            self._travel = np.where(flip, 0.0, self._travel + np.abs(dy))
            self._vsign = np.where(sign != 0, sign, self._vsign)

    @property
    def shaft_force(self) -> np.ndarray:
        """The structure force on the shaft after the last step (before any transport delay), N."""
        return self._history[0]

    def _move_nut(self) -> None:
        """Backlash: the nut follows the motor with a dead band of +-b."""
        bl = self.cfg.effects.backlash
        if not bl.enabled:
            self.nut_mm = self._lead().copy()
            return
        b = bl.half_width_mm
        m = self._lead()
        self.nut_mm = np.minimum(np.maximum(self.nut_mm, m - b), m + b)  # clip

    def _lead(self) -> np.ndarray:
        """Where the nut would be without backlash: the motor, plus lead_error's periodic part when on."""
        le = self.cfg.effects.lead_error
        if not le.enabled:
            return self.motor_mm
        return self.motor_mm + le.amplitude_mm * fmath.cos(
            2 * np.pi * self.motor_mm / le.period_mm + le.phase_rad
        )

    def _net_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Spring push minus structure reaction on the massless shaft, and its (negative) slope, for shaft
        advance y of the batch elements idx (all when None)."""
        d = pick(self.nut_mm, idx) - y
        fl, sl = self.structure_force(y, idx)
        return self.spring_force(d, idx) - fl, -self._spring_slope(d, idx) - sl

    def viscous_n_s_per_mm(self) -> float | np.ndarray:
        """The shaft's viscous drag coefficient this step (N s/mm; 0 without viscous friction)."""
        vf = self.cfg.effects.viscous_friction
        return vf.b_n_s_per_mm if vf.enabled else 0.0

    def _move_shaft(self, dt: float) -> None:
        """Quasi-static massless shaft: stick inside the friction band, else slide to its edge."""
        e = self.cfg.effects
        y0 = self.shaft_mm
        angle = self.geo.angle_from_shaft(np.minimum(y0, self.y_contact))
        fwd, rev = self.friction_limits(angle)
        if e.stribeck_friction.enabled:
            sf = e.stribeck_friction
            q = self.v_shaft / sf.v_s_mm_s
            boost = sf.extra_static_n * fmath.exp(-(q * q))
            fwd, rev = fwd + boost, rev + boost * (rev > 0)
        if e.rate_friction.enabled:
            rf = e.rate_friction
            boost = rf.extra_n * fmath.exp(-self._w / rf.v_c_mm_s)
            fwd, rev = fwd + boost, rev + boost
        if e.breakaway_friction.enabled:
            bk = e.breakaway_friction
            boost = bk.extra_n / (1.0 + np.power(self._wb / bk.v_s_mm_s, np.asarray(bk.shape, float)))
            fwd, rev = fwd + boost, rev + boost
        if e.bristle_friction.enabled:
            bf = e.bristle_friction
            band = bf.force_n * (1.0 - fmath.exp(-self._travel / bf.x0_mm))
            fwd, rev = fwd + band, rev + band
        if e.load_friction.enabled:  # the force the structure carried at the last step (its history)
            band = e.load_friction.mu * np.abs(self._history[0])
            fwd, rev = fwd + band, rev + band
        if e.position_friction.enabled:
            pf = e.position_friction
            q = np.abs((y0 - pf.center_mm) / pf.width_mm)
            band = pf.extra_n * fmath.exp(-np.power(q, np.asarray(pf.shape, float)))
            fwd, rev = fwd + band, rev + band
        n0, s0 = self._net_force(y0)
        b = self.viscous_n_s_per_mm() / dt
        target = np.where(n0 > fwd, fwd, np.where(n0 < -rev, -rev, n0))
        moving = target != n0
        y = y0.copy()
        if moving.any():
            y = self._solve(y0, (n0, s0), target, b, moving)
        self.v_shaft = (y - y0) / dt
        self.shaft_mm = y

    def _solve(
        self,
        y0: np.ndarray,
        net0: tuple[np.ndarray, np.ndarray],
        target: np.ndarray,
        b: np.ndarray | float,
        moving: np.ndarray,
    ) -> np.ndarray:
        """Solve net(y) - b (y - y0) = target for y by safeguarded Newton (net is decreasing in y): a step
        that leaves the bracket or fails to halve the previous one is replaced by bisection (plain Newton
        can cycle between two points across the contact kink and never converge).

        Only the moving elements iterate, each until its own step is below 1e-9 mm (at most 50 times),
        and a converged element leaves the active set. So an element's result depends only on its own
        inputs, never on the other elements of the batch: alone or in any batch it is bit-identical.
        net0 is _net_force(y0) (value, slope), which the first iteration reuses.
        """
        idx = np.flatnonzero(moving)
        f, s = net0[0][idx], net0[1][idx]
        y, y0a, ta, ba = y0.copy(), y0[idx], target[idx], pick(b, idx)
        # net falls at least as fast as the bare spring (slope >= k), which bounds the step.
        span = np.abs(f - ta) / self.k_spring
        up = f > ta
        lo, hi, ya = np.where(up, y0a, y0a - span), np.where(up, y0a + span, y0a), y0a
        last = np.full(idx.size, np.inf)  # the previous step's size
        for _ in range(50):
            r = f - ba * (ya - y0a) - ta
            beyond = r > 0  # the root lies beyond ya
            lo, hi = np.where(beyond, ya, lo), np.where(beyond, hi, ya)
            step = r / (s - ba)
            y_new = ya - step
            # bisect when Newton leaves the bracket or does not halve the step (it cycles at the kinks)
            ok = (y_new >= lo) & (y_new <= hi) & (2 * np.abs(step) <= last)
            y_new = np.where(ok, y_new, 0.5 * (lo + hi))
            last = np.abs(y_new - ya)
            done = last < 1e-9
            ya = y_new
            if done.any():
                y[idx[done]] = ya[done]
                keep = np.flatnonzero(~done)
                idx, ya, y0a, ta, lo, hi, ba, last = (
                    pick(x, keep) for x in (idx, ya, y0a, ta, lo, hi, ba, last)
                )
                if not idx.size:
                    break
            f, s = self._net_force(ya, idx)
        y[idx] = ya  # the few still unconverged after 50 iterations
        return y

    # --- sensors ----------------------------------------------------------------------------------
    def learned_inputs(self) -> dict[str, np.ndarray]:
        """The signals a learned residual may read (config.LEARNED_INPUTS), now."""
        return {
            "force_n": self.shaft_force,
            "speed_mm_s": self.v_shaft,
            "current": self.current,
            "contact_deg": self.contact_deg,
        }

    def _pot_angle(self) -> np.ndarray:
        """The pot's reading of the linkage angle now (counts, before its drop, noise and rounding)."""
        y_seen = np.minimum(self.shaft_mm, self.y_contact)  # the structure deforms beyond the pot
        return self.geo.pot_from_angle(self.geo.angle_from_shaft(y_seen))

    def read(self) -> Sensors:
        """Sample every sensor now (draws the noise of this sample)."""
        cfg, e, n = self.cfg, self.cfg.effects, self.nut_mm.size
        enc = np.floor(self.motor_mm / self.geo.mm_per_count + 1e-9).astype(np.int64)
        pot = self._pot_l if e.pot_lag.enabled else self._pot_angle()
        if e.pot_ripple.enabled:
            pr = e.pot_ripple
            pot = pot + pot_ripple(pot, pr.amplitude_counts, pr.period_counts, pr.phase_rad)
        if e.pot_voltage_drop.enabled:
            pot = pot + self.pot_drop
        if e.pot_reading_lag.enabled:
            a = reading_alpha(self.t - self._t_read, e.pot_reading_lag.time_constant_s)
            self._pot_r = pot if self._pot_r is None else lag_step(self._pot_r, pot, a)
            pot = self._pot_r
        self._t_read = self.t
        if e.pot_drift.enabled:
            pot = pot_distort(pot, self.t, (e.pot_drift.offset_counts, e.pot_drift.time_constant_s))
        if e.pot_hysteresis.enabled:
            w = e.pot_hysteresis.half_width_counts
            self._pot_h = (
                pot if self._pot_h is None else np.minimum(np.maximum(self._pot_h, pot - w), pot + w)
            )
            pot = self._pot_h
        if e.pot_noise.enabled:
            pot = pot + e.pot_noise.sigma_counts * self.rng.standard_normal(n)
        lr = e.learned_residual
        extra = learned_correction(lr, self.learned_inputs()) if lr.enabled else 0.0
        if lr.enabled and lr.channel == "pot":
            pot = pot + extra
        if e.pot_quantisation.enabled:
            pot = e.pot_quantisation.step_counts * np.rint(pot / e.pot_quantisation.step_counts)
        if e.pot_saturation.enabled:
            pot = pot_distort(pot, self.t, None, e.pot_saturation.limit_counts)
        pot_i = np.clip(np.rint(pot), 0, self.geo.adc_max).astype(np.int64)
        shaft_force = self._cell if e.cell_lag.enabled else self._history[self._delay_n]
        tip = shaft_force * self.ratio
        sigma = np.where(
            self.contact_deg <= self.geo.split_deg,
            cfg.load_cells.horizontal_sigma_n,
            cfg.load_cells.vertical_sigma_n,
        )
        load_cell = tip + sigma * self.rng.standard_normal(n)
        if e.load_cell_offset.enabled:
            load_cell = load_cell + e.load_cell_offset.offset_n
        if lr.enabled and lr.channel == "load_cell_n":
            load_cell = load_cell + extra
        load_cell = cell_terms(e, load_cell, self.t)
        if e.cell_hysteresis.enabled:  # after the cell's other terms
            ch = e.cell_hysteresis
            z = np.zeros(n) if self._cell_z is None else self._cell_z
            dx = tip - (tip if self._cell_z is None else self._cell_tip)
            self._cell_z, self._cell_tip = hysteresis_step(z, dx, ch.width_n, ch.shape), tip
            load_cell = load_cell + ch.force_n * self._cell_z
        true_force = self.structure_force(self.shaft_mm)[0]
        return Sensors(
            enc=enc,
            pot=pot_i,
            load_cell_n=load_cell,
            force_n=load_cell / self.ratio,
            true_force_n=true_force,
            angle_deg=self.geo.angle_from_shaft(self.shaft_mm),
            compression_mm=self.nut_mm - self.shaft_mm,
            motor_current=self.current.copy(),
        )
