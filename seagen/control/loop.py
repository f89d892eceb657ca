"""The closed loop: the simulated SEA at 1 kHz, the controller (C or its Python twin) ticking at the
actuator's loop rate (the description's control.loop_hz: 100 Hz for the paper's)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from types import ModuleType
from typing import Any

import numpy as np

from seagen.control.link import BleLink, make_link
from seagen.errors import UserError
from seagen.plant import Plant, PlantConfig
from seagen.runtime.actq import act_q
from seagen.runtime.control import ControlConfig, ControlState, Predictor, control_reset, control_step, q16
from seagen.runtime.control import set_desired as py_set_desired

PLANT_FIELDS = ("motor_mm", "v_motor", "nut_mm", "shaft_mm", "v_shaft", "current", "pot_drop")
SENSOR_FIELDS = ("enc", "pot", "force_n", "true_force_n", "compression_mm", "angle_deg")
CTRL_FIELDS = ("desired", "comp", "pot_avg", "fault")


@dataclass(frozen=True)
class McuPredictor:
    """A fixed-point predictor on the MCU: its C symbol, a ctx factory (one ctx per actuator when
    `stateful`), a factory of its Python twin (a fresh twin per run), its call period."""

    c_symbol: str
    make_ctx: Callable[[ModuleType], object]
    make_twin: Callable[[], Predictor]
    predict_every: int = 1  # predict every tick (1), every 10th tick (10), ...
    cdef: str = ""
    sources: dict[str, str] = field(default_factory=dict)
    stateful: bool = False


@dataclass(frozen=True)
class CloudPredictor:
    """A float predictor off the MCU: (enc rows, pot rows, force N) -> compression mm over a wireless link.

    `fn` gets three rows of enc and pot (the oldest first) and the desired force. `link` is the Bluetooth LE
    link as the paper ran it (seagen.control.link.BleLink: 10 Hz rounds of one sample, connection events,
    retransmission, the PC's turnaround); None is the idealised link: the last three loop-rate samples with
    each request at a `refresh_hz` slot with no reply outstanding, the reply applied `latency_s` later.
    """

    fn: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    latency_s: float = 0.1  # the idealised link's round trip
    refresh_hz: float = 10.0
    link: BleLink | None = None


# The controller: "c" (built by cffi), "py" (the Python twin), or a maker (predictor, configuration) ->
# controller that a driver built (the firmware on an emulated board: seagen.setups.pil.loop_controller).
Impl = str | Callable[[McuPredictor | CloudPredictor, ControlConfig], Any]


class PyController:
    """The Python twin with the CController interface."""

    def __init__(self, c: ControlConfig) -> None:
        self.c = c
        self.s: ControlState | None = None

    def reset(self, enc: np.ndarray, pot: np.ndarray) -> None:
        """control_reset for the batch."""
        self.s = control_reset(self.c, enc, pot)

    def step(self, enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
        """control_step for the batch; returns the commands (mV)."""
        assert self.s is not None
        self.s = control_step(self.c, self.s, enc, pot, force_q16)
        return self.s.out

    def set_desired(self, desired_q16: np.ndarray) -> None:
        """set_desired for the batch."""
        assert self.s is not None
        self.s = py_set_desired(self.s, desired_q16)

    def field(self, name: str) -> np.ndarray:
        """One int field of the state."""
        return np.asarray(getattr(self.s, name), dtype=np.int64)


def make_controller(impl: Impl, pred: McuPredictor | CloudPredictor, c: ControlConfig) -> Any:
    """The C (`impl='c'`, built by cffi) or Python (`'py'`) controller for this predictor, or the one the
    maker `impl` builds (e.g. the firmware in QEMU on an emulated board: seagen.setups.pil)."""
    if isinstance(pred, McuPredictor):  # the C controller calls the C predictor; only the twin needs its twin
        c = replace(c, predictor=pred.make_twin() if impl == "py" else None, predict_every=pred.predict_every)
    else:
        c = replace(c, predictor=None)
    if impl == "py":
        return PyController(c)
    if callable(impl):
        return impl(pred, c)
    if impl != "c":
        raise ValueError(f"impl must be 'c', 'py' or a controller maker, not {impl!r}")
    from seagen.toolchain.controller import CController, build_control

    if isinstance(pred, McuPredictor):
        mod = build_control(pred.cdef, pred.sources)
        if pred.stateful:
            return CController(mod, c, pred.c_symbol, make_ctx=pred.make_ctx)
        return CController(mod, c, pred.c_symbol, pred.make_ctx(mod))
    return CController(build_control(), c, None)


# (tick, enc, pot) -> (enc, pot): sensor faults injected between the plant and the controller
SensorHook = Callable[[int, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def run_closed_loop(
    pred: McuPredictor | CloudPredictor,
    target_n: float | Callable[[int], float],
    contact_deg: np.ndarray | float,
    *,
    impl: Impl = "c",
    duration_s: float = 10.0,
    seed: int = 0,
    plant_cfg: PlantConfig | None = None,
    control_cfg: ControlConfig | None = None,
    sensor_hook: SensorHook | None = None,
) -> dict[str, np.ndarray]:
    """Run the experiment; returns per-tick records (ticks x actuators) of sensors, controller and plant."""
    plant = Plant(plant_cfg or PlantConfig(), contact_deg, seed=seed)
    control_cfg = control_cfg or ControlConfig.for_act(act_q(plant.cfg.actuator))
    if control_cfg.act.digest != plant.cfg.actuator.digest():
        raise UserError(
            f"the controller was made for actuator '{control_cfg.act.name}', the plant simulates "
            f"'{plant.cfg.actuator.name}'"
        )
    ctrl = make_controller(impl, pred, control_cfg)
    try:
        return _run(plant, ctrl, pred, target_n, duration_s, sensor_hook, seed)
    finally:
        if hasattr(ctrl, "close"):  # a board in QEMU
            ctrl.close()


def plant_steps_per_tick(cfg: PlantConfig) -> int:
    """Plant steps per controller tick: the loop period in plant steps (protocol.py holds it whole)."""
    return int(round(1.0 / (cfg.actuator.loop_hz * cfg.dt_s)))


def _run(
    plant: Plant, ctrl, pred, target_n, duration_s: float, sensor_hook, seed: int
) -> dict[str, np.ndarray]:
    """The loop of run_closed_loop with its plant and controller."""
    steps = plant_steps_per_tick(plant.cfg)
    tick_s = 1.0 / plant.cfg.actuator.loop_hz
    s = plant.read()
    ctrl.reset(s.enc, s.pot)
    target = target_n if callable(target_n) else (lambda _k: float(target_n))
    cloud = make_link(pred, tick_s, seed) if isinstance(pred, CloudPredictor) else None
    rec: dict[str, list[np.ndarray]] = {}
    for k in range(int(round(duration_s / tick_s))):
        s = plant.read()
        enc, pot = sensor_hook(k, s.enc, s.pot) if sensor_hook else (s.enc, s.pot)
        f_n = target(k)
        if cloud is not None:
            cloud.tick(ctrl, k, enc, pot, f_n)
        out = ctrl.step(enc, pot, np.full(enc.shape, q16(f_n), dtype=np.int64))
        _record(rec, k * tick_s, s, plant, ctrl, out, enc, pot, f_n)
        for _ in range(steps):
            plant.step(out / 1000.0)
    return {k: np.array(v) for k, v in rec.items()}


def _record(rec, t_s: float, s, plant: Plant, ctrl, out: np.ndarray, enc, pot, f_n: float) -> None:
    """Append this tick's sensors (as seen by the controller), controller fields and plant state."""
    row = {f: getattr(s, f) for f in SENSOR_FIELDS}
    row.update(enc=enc, pot=pot, out_mv=out, target_n=np.full(enc.shape, f_n), t_s=np.full(enc.shape, t_s))
    row.update({f: ctrl.field(f) for f in CTRL_FIELDS})
    row.update({f: getattr(plant, f) for f in PLANT_FIELDS})
    for name, v in row.items():
        rec.setdefault(name, []).append(np.array(v, copy=True))
