"""Blind hidden-effect forms (issue 39 item 3): truth plants written apart from the term library and its rule.

Each form is a Plant subclass that adds one law of its own (a force in the drive, spring or shaft, or a
distortion of one sensor's reading) on top of the default plant, which stays on in both the truth and the
base: the workflow starts from the plant as it is, and only the form is hidden. Each form's parameters are
drawn per case from the stated range (pot counts as shares of the pot's full scale, like families.py).

What each form should be found as was fixed before any run: `expected_class` (one of CLASSES), the logged
channels it changes (`channels`: "force" = load_cell_n, "position" = enc and pot, "both"), and the true
values of its key physical parameters (`blind_case`'s expectations, for a scorer). The two "other" forms
are none of the classes cleanly (a humility test: the right answer is no named class, or unexplained).

Drifts run on a session clock: trial i of a case (the order of bench.case_moves) starts SESSION_GAP_S * i
seconds into the session (a trial and a pause), so the same trial index means the same session time.

Visibility, measured after the expectations above were committed (commit 634a10e) and unchanged since:
`signal_change` replays the same commands and noise into the plain plant and each form's (open loop) and
gives each channel's RMS change in noise sigmas. Every form moves its strongest channel by more than the
noise in every seed; the sensor forms leave the channels they do not act on exactly unchanged. Weakest:
thread_error (enc 1.7, load cell 0.7 sigma at worst) and gear_detent's and presliding_bristle's force
channel (0.45 and 0.9 sigma at worst; their position channel carries them). Reproduce with
`.venv/bin/python -c "from seagen.discrepancy.blindforms import visibility_table as v; print(v())"`:

    full protocol (PUSH_MOVES), seeds [1, 2, 3, 4, 5]: median [min] of RMS change / noise sigma
    form                 class                channels             enc            pot    load_cell_n
    thread_error         periodic             both         3.36 [ 1.69]    1.33 [ 0.96]    1.13 [ 0.71]
    gear_detent          periodic             both        49.50 [13.49]    1.12 [ 0.19]    1.73 [ 0.45]
    spring_relaxation    drift                both        63.04 [52.89]    1.17 [ 0.98]    3.36 [ 2.83]
    pot_zero_drift       drift                position     0.00 [ 0.00]    4.78 [ 3.80]    0.00 [ 0.00]
    presliding_bristle   state_friction       both         3.83 [ 2.58]    2.01 [ 1.31]    1.54 [ 0.88]
    lagged_breakaway     state_friction       both        41.43 [12.88]    5.07 [ 2.86]    6.57 [ 1.70]
    spring_hysteresis    hysteresis           both        66.38 [39.33]    2.58 [ 1.27]    5.62 [ 3.24]
    cell_hysteresis      hysteresis           force        0.00 [ 0.00]    0.00 [ 0.00]    5.22 [ 3.27]
    progressive_spring   nonlinear_stiffness  both       184.49 [113.59]    3.64 [ 2.18]   12.34 [ 7.72]
    pot_lag              sensor_lag           position     0.00 [ 0.00]    9.95 [ 5.74]    0.00 [ 0.00]
    cell_quantised       quantisation         force        0.00 [ 0.00]    0.00 [ 0.00]    1.85 [ 1.24]
    cell_saturation      saturation           force        0.00 [ 0.00]    0.00 [ 0.00]   21.94 [11.51]
    pot_clamp            saturation           position     0.00 [ 0.00]   23.98 [14.71]    0.00 [ 0.00]
    drive_crosstalk      other                force        0.00 [ 0.00]    0.00 [ 0.00]    4.35 [ 2.77]
    angle_gain           other                force        0.00 [ 0.00]    0.00 [ 0.00]    4.35 [ 2.79]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from seagen.actuator import Actuator, default_actuator
from seagen.geometry import geometry
from seagen.plant import Plant, PlantConfig, pick
from seagen.plant.config import pot_full_scale

CLASSES = (
    "periodic",
    "drift",
    "state_friction",
    "hysteresis",
    "nonlinear_stiffness",
    "sensor_lag",
    "quantisation",
    "saturation",
    "other",
)
CHANNEL_NAMES = ("enc", "pot", "load_cell_n")  # the logged channels signal_change compares
SESSION_GAP_S = 10.0  # s between the starts of consecutive trials on the session clock


def session_clock(plant: Plant) -> np.ndarray:
    """Seconds since the session's start of every batch element (trial i starts SESSION_GAP_S * i)."""
    return plant.t + SESSION_GAP_S * np.arange(plant.nut_mm.size)


def _state(plant: Plant, name: str, like: np.ndarray, value: float = 0.0) -> np.ndarray:
    """A per-element state of the form (created at `value` on first use)."""
    if not hasattr(plant, name):
        setattr(plant, name, np.full(like.shape, value, dtype=float))
    out: np.ndarray = getattr(plant, name)
    return out


def _sample_alpha(plant: Plant, tau_s: float) -> float:
    """Weight of a first-order lag of time constant tau_s updated once per logged sample."""
    return 1.0 - math.exp(-1.0 / plant.cfg.actuator.loop_hz / tau_s)


def _pot_clean(plant: Plant) -> np.ndarray:
    """The pot's noise-free, unrounded value now (what the ADC would read without noise)."""
    pot: np.ndarray = plant.geo.pot_from_angle(
        plant.geo.angle_from_shaft(np.minimum(plant.shaft_mm, plant.y_contact))
    )
    if plant.cfg.on("pot_voltage_drop"):
        pot = pot + plant.pot_drop
    return pot


def _repot(plant: Plant, pot: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """An integer pot reading moved by `delta` counts, rounded and clipped to the ADC."""
    return np.clip(np.rint(pot + delta), 0, plant.geo.adc_max).astype(np.int64)


# --- periodic in position -------------------------------------------------------------------------------
class ThreadError(Plant):
    """Lead-screw thread error: the nut runs ahead of or behind the motor by a sinusoid of the motor's travel,
    e = a sin(2 pi x / period + phase) (a multi-start screw's per-start pitch error; lead / starts)."""

    amplitude_mm: float
    period_mm: float
    phase_rad: float

    def _move_nut(self) -> None:
        """The plant's nut, shifted by the thread error at the motor's position."""
        super()._move_nut()
        self.nut_mm = self.nut_mm + self.amplitude_mm * np.sin(
            2 * np.pi * self.motor_mm / self.period_mm + self.phase_rad
        )


class GearDetent(Plant):
    """Detent torque of the gear train's output stage, felt at the nut as a load ripple
    r = A sin(2 pi x / period + phase) of the motor's travel x; applied through the linear motor model as the
    equivalent voltage A supply / stall (so the current reads the torque net of the ripple)."""

    amplitude_n: float
    period_mm: float
    phase_rad: float

    def step(self, motor_v: Any) -> None:
        """Step with the command less the ripple's equivalent voltage."""
        m = self.motor
        volts = np.clip(np.asarray(motor_v, dtype=float), -m.supply_v, m.supply_v)
        ripple = self.amplitude_n * np.sin(2 * np.pi * self.motor_mm / self.period_mm + self.phase_rad)
        super().step(volts - ripple * m.supply_v / m.stall_force_n)


# --- drift in time --------------------------------------------------------------------------------------
class SpringRelaxation(Plant):
    """The spring softens as it warms over the session: rate k (1 - drop (1 - exp(-t / tau))) on positive
    compression, t on the session clock."""

    drop: float  # share of the stiffness lost at the end
    tau_s: float

    def _loss(self, idx: np.ndarray | None) -> np.ndarray:
        """Stiffness lost now (N/mm) at the batch elements idx (all when None)."""
        lost = self.k_spring * self.drop * (1.0 - np.exp(-session_clock(self) / self.tau_s))
        out: np.ndarray = pick(lost, idx)
        return out

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The plant's spring less the lost stiffness times positive compression."""
        return super().spring_force(d, idx) - self._loss(idx) * np.maximum(d, 0.0)

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """Its slope."""
        return super()._spring_slope(d, idx) - self._loss(idx) * (d >= 0)


class PotZeroDrift(Plant):
    """The pot's zero creeps as its electronics warm: offset o (1 - exp(-t / tau)) counts, session clock."""

    offset_counts: float
    tau_s: float

    def read(self):
        """The reading plus the drifted zero."""
        s = super().read()
        drift = self.offset_counts * (1.0 - np.exp(-session_clock(self) / self.tau_s))
        s.pot = _repot(self, s.pot, drift)
        return s


# --- state-dependent friction ---------------------------------------------------------------------------
class PreslidingBristle(Plant):
    """Elastoplastic (single-bristle) friction: the plant's friction band is reached through a bristle of
    stiffness band / presliding_mm, so the shaft moves elastically before it breaks away and springs back
    at a reversal. The bristle's anchor slides when its force would leave the band (forward limit on
    forward slip, reverse limit on reverse slip). Viscous and Stribeck terms of the base are not carried."""

    presliding_mm: float  # displacement at which the forward band is reached from a relaxed bristle

    def _move_shaft(self, dt: float) -> None:
        """Quasi-static massless shaft held by spring, structure and the bristle."""
        y0 = self.shaft_mm
        anchor = _state(self, "_anchor", y0)
        angle = self.geo.angle_from_shaft(np.minimum(y0, self.y_contact))
        fwd, rev = self.friction_limits(angle)
        sigma = np.maximum(fwd, 1e-3) / self.presliding_mm  # N/mm
        everyone = np.ones(y0.shape, dtype=bool)
        net0 = self._net_force(y0)
        # elastic: net(y) = sigma (y - anchor)  <=>  net(y) - sigma (y - y0) = sigma (y0 - anchor)
        y = self._solve(y0, net0, sigma * (y0 - anchor), sigma, everyone)
        pull = sigma * (y - anchor)
        ahead, back = pull > fwd, pull < -rev
        if (ahead | back).any():
            slide = self._solve(y0, net0, np.where(ahead, fwd, -rev), 0.0, ahead | back)
            y = np.where(ahead | back, slide, y)
            anchor = np.where(ahead, y - fwd / sigma, np.where(back, y + rev / sigma, anchor))
        self._anchor = anchor
        self.v_shaft = (y - y0) / dt
        self.shaft_mm = y


class LaggedBreakaway(Plant):
    """Frictional memory: extra break-away friction fs / (1 + (w / vs)^2), where w is the shaft's speed
    through a first-order lag of time constant tau (the contact's state takes time to follow the speed)."""

    fs_n: float
    vs_mm_s: float
    tau_s: float

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's band plus the break-away term of the lagged speed."""
        fwd, rev = super().friction_limits(angle_deg)
        w = _state(self, "_w", fwd)
        boost = self.fs_n / (1.0 + (w / self.vs_mm_s) ** 2)
        return fwd + boost, rev + boost

    def step(self, motor_v: Any) -> None:
        """Step, then let the lagged speed follow |shaft speed|."""
        super().step(motor_v)
        w = _state(self, "_w", self.v_shaft)
        self._w = w + (np.abs(self.v_shaft) - w) * min(self.cfg.dt_s / self.tau_s, 1.0)


# --- hysteresis -----------------------------------------------------------------------------------------
class SpringHysteresis(Plant):
    """Internal friction of the spring (coil rubbing): its force gains h z on compression, the state z in
    [-1, 1] moving toward the sign of the compression's change over a width x_h of compression change
    (dz = |dd| / x_h (sign(dd) - z)); held while the solver moves."""

    h_n: float
    width_mm: float

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The plant's spring plus the hysteretic term where compressed."""
        z = pick(_state(self, "_z", self.nut_mm), idx)
        return super().spring_force(d, idx) + self.h_n * z * (d > 0)

    def step(self, motor_v: Any) -> None:
        """Step, then move the state by the change of compression."""
        d0 = self.nut_mm - self.shaft_mm
        super().step(motor_v)
        dd = (self.nut_mm - self.shaft_mm) - d0
        z = _state(self, "_z", dd)
        rate = np.minimum(np.abs(dd) / self.width_mm, 1.0)
        self._z = z + rate * (np.sign(dd) - z)


class CellHysteresis(Plant):
    """Load-cell hysteresis (strain-gauge bond creep): the reading gains h z, z in [-1, 1] moving toward the
    sign of the tip force's change over a width f_h of force change, updated per reading."""

    h_n: float
    width_n: float

    def read(self):
        """The reading plus the hysteretic term."""
        s = super().read()
        tip = self.shaft_force * self.ratio
        prev = _state(self, "_tip", tip)
        z = _state(self, "_zc", tip)
        df = tip - prev
        z = z + np.minimum(np.abs(df) / self.width_n, 1.0) * (np.sign(df) - z)
        self._tip, self._zc = tip.copy(), z
        s.load_cell_n = s.load_cell_n + self.h_n * z
        s.force_n = s.load_cell_n / self.ratio
        return s


# --- nonlinear stiffness --------------------------------------------------------------------------------
class ProgressiveSpring(Plant):
    """A progressive spring (coils closing up): force k d + k2 d^2 on positive compression d."""

    k2_n_per_mm2: float

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The plant's spring plus the quadratic term."""
        dp = np.maximum(d, 0.0)
        return super().spring_force(d, idx) + self.k2_n_per_mm2 * dp * dp

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """Its slope."""
        return super()._spring_slope(d, idx) + 2 * self.k2_n_per_mm2 * np.maximum(d, 0.0)


# --- sensor lag -----------------------------------------------------------------------------------------
class PotLag(Plant):
    """An RC filter on the pot's line: the noise-free pot value through a first-order lag of time constant
    tau (sampled at the loop rate); the ADC's own noise and rounding come after it."""

    tau_s: float

    def read(self):
        """The reading moved by the lagged minus the present noise-free value."""
        s = super().read()
        clean = _pot_clean(self)
        lagged = _state(self, "_pl", clean)
        lagged = lagged + _sample_alpha(self, self.tau_s) * (clean - lagged)
        self._pl = lagged
        s.pot = _repot(self, s.pot, lagged - clean)
        return s


# --- quantisation ---------------------------------------------------------------------------------------
class CellQuantised(Plant):
    """A coarse load-cell ADC: the tip reading (with its noise) rounded to steps of q newtons."""

    step_n: float

    def read(self):
        """The reading rounded to the step."""
        s = super().read()
        s.load_cell_n = self.step_n * np.rint(s.load_cell_n / self.step_n)
        s.force_n = s.load_cell_n / self.ratio
        return s


# --- saturation -----------------------------------------------------------------------------------------
class CellSaturation(Plant):
    """The load-cell amplifier saturates: linear up to a knee at 80 % of f_sat, then tanh-rounded to f_sat
    (both signs)."""

    f_sat_n: float

    def read(self):
        """The reading through the amplifier's limit."""
        s = super().read()
        knee = 0.8 * self.f_sat_n
        room = self.f_sat_n - knee
        x = s.load_cell_n
        over = np.abs(x) > knee
        s.load_cell_n = np.where(over, np.sign(x) * (knee + room * np.tanh((np.abs(x) - knee) / room)), x)
        s.force_n = s.load_cell_n / self.ratio
        return s


class PotClamp(Plant):
    """The pot's input divider clamps: readings above c_sat counts read c_sat."""

    sat_counts: float

    def read(self):
        """The reading clamped."""
        s = super().read()
        s.pot = np.minimum(s.pot, int(round(self.sat_counts))).astype(np.int64)
        return s


# --- other (none of the classes cleanly) -----------------------------------------------------------------
class DriveCrosstalk(Plant):
    """The motor drive couples into the load-cell amplifier: the reading gains g times the command (V) of
    the last step (PWM pickup), whatever the force."""

    gain_n_per_v: float

    def step(self, motor_v: Any) -> None:
        """Step, remembering the command."""
        super().step(motor_v)
        self._cmd = np.broadcast_to(np.asarray(motor_v, dtype=float), self.nut_mm.shape).copy()

    def read(self):
        """The reading plus the pickup."""
        s = super().read()
        s.load_cell_n = s.load_cell_n + self.gain_n_per_v * _state(self, "_cmd", s.load_cell_n)
        s.force_n = s.load_cell_n / self.ratio
        return s


class AngleGain(Plant):
    """A tilted load-cell mount whose tilt grows along the linkage's range: the cell reads the tip force
    times 1 + g (angle - mid) / half-span (mid and half-span of the linkage's angle range)."""

    gain: float

    def read(self):
        """The reading scaled by the angle-dependent gain."""
        s = super().read()
        geo = self.geo
        mid = 0.5 * (geo.angle_min_deg + geo.angle_max_deg)
        half = 0.5 * (geo.angle_max_deg - geo.angle_min_deg)
        s.load_cell_n = s.load_cell_n * (1.0 + self.gain * (self.contact_deg - mid) / half)
        s.force_n = s.load_cell_n / self.ratio
        return s


@dataclass(frozen=True)
class Form:
    """A blind form: its truth plant class, parameter ranges, and what it should be found as (fixed)."""

    cls: type[Plant]
    expected_class: str
    channels: str  # "force" (load_cell_n), "position" (enc, pot) or "both"
    ranges: dict[str, tuple[float, float]]
    pot_counts: frozenset[str] = frozenset()  # parameters in pot counts: ranges as shares of full scale

    def bounds(self, act: Actuator | None = None) -> dict[str, tuple[float, float]]:
        """The parameter ranges in the plant's units on actuator `act` (the paper's when None)."""
        fs = pot_full_scale(act or default_actuator())
        return {
            k: (lo * fs, hi * fs) if k in self.pot_counts else (lo, hi) for k, (lo, hi) in self.ranges.items()
        }


PHASE = (0.0, 2 * math.pi)
FORMS: dict[str, Form] = {
    "thread_error": Form(
        ThreadError,
        "periodic",
        "both",
        {"amplitude_mm": (0.03, 0.08), "period_mm": (1.0, 4.0), "phase_rad": PHASE},
    ),
    "gear_detent": Form(
        GearDetent,
        "periodic",
        "both",
        {"amplitude_n": (1.5, 4.0), "period_mm": (0.6, 2.0), "phase_rad": PHASE},
    ),
    "spring_relaxation": Form(
        SpringRelaxation, "drift", "both", {"drop": (0.06, 0.15), "tau_s": (20.0, 80.0)}
    ),
    "pot_zero_drift": Form(
        PotZeroDrift,
        "drift",
        "position",
        {"offset_counts": (0.01, 0.03), "tau_s": (20.0, 80.0)},  # 41 to 123 counts of 12 bits
        frozenset({"offset_counts"}),
    ),
    "presliding_bristle": Form(PreslidingBristle, "state_friction", "both", {"presliding_mm": (0.08, 0.25)}),
    "lagged_breakaway": Form(
        LaggedBreakaway,
        "state_friction",
        "both",
        {"fs_n": (1.0, 2.5), "vs_mm_s": (0.3, 1.5), "tau_s": (0.02, 0.1)},
    ),
    "spring_hysteresis": Form(
        SpringHysteresis, "hysteresis", "both", {"h_n": (0.5, 1.5), "width_mm": (0.05, 0.2)}
    ),
    "cell_hysteresis": Form(
        CellHysteresis, "hysteresis", "force", {"h_n": (0.2, 0.6), "width_n": (0.5, 2.0)}
    ),
    "progressive_spring": Form(
        ProgressiveSpring, "nonlinear_stiffness", "both", {"k2_n_per_mm2": (0.15, 0.5)}
    ),
    "pot_lag": Form(PotLag, "sensor_lag", "position", {"tau_s": (0.02, 0.08)}),
    "cell_quantised": Form(CellQuantised, "quantisation", "force", {"step_n": (0.25, 0.6)}),
    "cell_saturation": Form(CellSaturation, "saturation", "force", {"f_sat_n": (6.0, 10.0)}),
    "pot_clamp": Form(
        PotClamp,
        "saturation",
        "position",
        {"sat_counts": (0.40, 0.50)},  # 1638 to 2048 counts of 12 bits
        frozenset({"sat_counts"}),
    ),
    "drive_crosstalk": Form(DriveCrosstalk, "other", "force", {"gain_n_per_v": (0.04, 0.1)}),
    "angle_gain": Form(AngleGain, "other", "force", {"gain": (0.04, 0.1)}),
}
BLIND_FORMS = tuple(FORMS)


def _derived(name: str, params: dict[str, float], cfg: PlantConfig) -> dict[str, float]:
    """Key parameters in the units a scorer may report besides the drawn ones (e.g. a nut error as the
    spring force it makes)."""
    k = geometry(cfg.actuator).spring_n_per_mm
    if name == "thread_error":
        return {"amplitude_n": params["amplitude_mm"] * k}
    if name == "spring_relaxation":
        return {"stiffness_loss_n_per_mm": params["drop"] * k}
    if name == "spring_hysteresis":
        return {"amplitude_n": params["h_n"]}
    if name == "cell_hysteresis":
        return {"amplitude_n": params["h_n"]}
    return {}


def blind_case(
    name: str, seed: int, act: Actuator | None = None
) -> tuple[type[Plant], PlantConfig, PlantConfig, dict[str, Any]]:
    """(truth plant class, truth config, base config, committed expectations) of one case of form `name` on
    actuator `act` (the paper's when None). The configs are the same default plant (the form is the only
    thing hidden); the expectations: form, expected_class, channels, truth (the drawn parameters and
    derived ones in physical units)."""
    rng = np.random.default_rng(seed)
    form = FORMS[name]
    cfg = PlantConfig(actuator=act or default_actuator())
    params = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in form.bounds(cfg.actuator).items()}
    cls = type(f"{form.cls.__name__}_{seed}", (form.cls,), params)
    expect = {
        "form": name,
        "expected_class": form.expected_class,
        "channels": form.channels,
        "truth": {**params, **_derived(name, params, cfg)},
    }
    return cls, cfg, cfg, expect


def _open_loop(plant: Plant, volts: np.ndarray, every: int) -> dict[str, np.ndarray]:
    """Logged channels (samples, elements) of `plant` driven by the command volts (samples, elements), each
    held for `every` plant steps after its sample (run_trials' order: read, then step)."""
    out: dict[str, list[np.ndarray]] = {c: [] for c in CHANNEL_NAMES}
    for v in volts:
        s = plant.read()
        for c in out:
            out[c].append(np.asarray(getattr(s, c), float).copy())
        for _ in range(every):
            plant.step(v)
    return {c: np.array(x) for c, x in out.items()}


def signal_change(
    names: tuple[str, ...] = BLIND_FORMS,
    seed: int = 1,
    fast: bool = True,
    act: Actuator | None = None,
    max_s: float | None = None,
) -> dict[str, dict[str, float]]:
    """Per form of `names`: the RMS change it makes to each logged channel (enc, pot, load_cell_n) in units
    of that channel's sensor noise (enc: its rounding, 1/sqrt(12) count; pot: pot_noise's sigma; load cell:
    its mount's sigma). The bench's case trials (FAST_MOVES if `fast`; each at most max_s seconds when
    given) run closed loop once by the plain plant; its logged commands are replayed open loop into the
    plain plant and into each form's case `seed`, with the same seed (the same noise draws)."""
    from seagen.data.protocol import run_trials, sample_every
    from seagen.discrepancy.bench import FAST_MOVES, case_moves
    from seagen.discrepancy.residuals import QUANT_SIGMA

    truth = PlantConfig(actuator=act or default_actuator())
    moves = case_moves(FAST_MOVES, truth.actuator) if fast else case_moves(act=truth.actuator)
    frames = run_trials(truth, moves, seed=seed, max_s=max_s)
    n = max(len(f) for f in frames)
    volts = np.zeros((n, len(moves)))
    alive = np.zeros((n, len(moves)), dtype=bool)
    for i, f in enumerate(frames):
        volts[: len(f), i], alive[: len(f), i] = f["motor_v"].to_numpy(float), True
    angles = np.array([m.angle_deg for m in moves])
    every = sample_every(truth)
    plain = _open_loop(Plant(truth, angles, seed=seed), volts, every)
    lc = truth.load_cells
    split = geometry(truth.actuator).split_deg
    sigma = {
        "enc": np.full(angles.size, QUANT_SIGMA),
        "pot": np.full(angles.size, truth.effects.pot_noise.sigma_counts),
        "load_cell_n": np.where(angles <= split, lc.horizontal_sigma_n, lc.vertical_sigma_n),
    }
    out = {}
    for name in names:
        cls, cfg, _, _ = blind_case(name, seed, act)
        formed = _open_loop(cls(cfg, angles, seed=seed), volts, every)
        out[name] = {
            c: float(np.sqrt(np.mean(((formed[c] - plain[c]) / sigma[c])[alive] ** 2))) for c in plain
        }
    return out


def visibility_table(seeds: range | tuple[int, ...] = range(1, 6), fast: bool = False) -> str:
    """signal_change over `seeds` as text: per form and channel, the median [min] over the seeds."""
    res = [signal_change(seed=s, fast=fast) for s in seeds]
    head = "full protocol (PUSH_MOVES)" if not fast else "fast protocol (FAST_MOVES)"
    lines = [
        f"{head}, seeds {list(seeds)}: median [min] of RMS change / noise sigma",
        f"{'form':20s} {'class':20s} {'channels':9s} " + " ".join(f"{c:>14s}" for c in CHANNEL_NAMES),
    ]
    for name in BLIND_FORMS:
        cells = []
        for c in CHANNEL_NAMES:
            v = np.array([r[name][c] for r in res])
            cells.append(f"{np.median(v):7.2f} [{v.min():5.2f}]")
        form = FORMS[name]
        lines.append(f"{name:20s} {form.expected_class:20s} {form.channels:9s} " + " ".join(cells))
    return "\n".join(lines)
