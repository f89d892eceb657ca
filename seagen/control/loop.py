"""The closed loop: the simulated SEA at 1 kHz, the controller (C or its Python twin) ticking at 100 Hz."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from types import ModuleType

import numpy as np

from seagen.control.controller import ControlConfig, ControlState, Predictor, control_reset, control_step, q16
from seagen.control.controller import set_desired as py_set_desired
from seagen.plant import Plant, PlantConfig

PLANT_STEPS_PER_TICK = 10  # 1 kHz plant, 100 Hz controller
TICK_S = 0.01
PLANT_FIELDS = ("motor_mm", "v_motor", "nut_mm", "shaft_mm", "v_shaft", "current", "pot_drop")
SENSOR_FIELDS = ("enc", "pot", "force_n", "true_force_n", "compression_mm", "angle_deg")
CTRL_FIELDS = ("desired", "comp", "pot_avg", "fault")


@dataclass(frozen=True)
class McuPredictor:
    """A fixed-point predictor on the MCU: its C symbol (and ctx), its Python twin, its call period."""

    c_symbol: str
    make_ctx: Callable[[ModuleType], object]
    twin: Predictor
    predict_every: int = 1  # 1 = 100 Hz, 10 = 10 Hz
    cdef: str = ""
    sources: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class CloudPredictor:
    """A float predictor off the MCU: (enc, pot, force N) -> compression mm, refreshed and delayed."""

    fn: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    latency_s: float = 0.1  # Bluetooth round trip
    refresh_hz: float = 10.0


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


def make_controller(impl: str, pred: McuPredictor | CloudPredictor, c: ControlConfig) -> object:
    """The C (`impl='c'`, built by cffi) or Python (`'py'`) controller for this predictor."""
    if isinstance(pred, McuPredictor):
        c = replace(c, predictor=pred.twin, predict_every=pred.predict_every)
    else:
        c = replace(c, predictor=None)
    if impl == "py":
        return PyController(c)
    from seagen.control.cbuild import CController, build_control

    if isinstance(pred, McuPredictor):
        mod = build_control(pred.cdef, pred.sources)
        return CController(mod, c, pred.c_symbol, pred.make_ctx(mod))
    return CController(build_control(), c, None)


# (tick, enc, pot) -> (enc, pot): sensor faults injected between the plant and the controller
SensorHook = Callable[[int, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def run_closed_loop(
    pred: McuPredictor | CloudPredictor,
    target_n: float | Callable[[int], float],
    contact_deg: np.ndarray | float,
    *,
    impl: str = "c",
    duration_s: float = 10.0,
    seed: int = 0,
    plant_cfg: PlantConfig | None = None,
    control_cfg: ControlConfig | None = None,
    sensor_hook: SensorHook | None = None,
) -> dict[str, np.ndarray]:
    """Run the experiment; returns per-tick records (ticks x actuators) of sensors, controller and plant."""
    plant = Plant(plant_cfg or PlantConfig(), contact_deg, seed=seed)
    ctrl = make_controller(impl, pred, control_cfg or ControlConfig())
    s = plant.read()
    ctrl.reset(s.enc, s.pot)
    target = target_n if callable(target_n) else (lambda _k: float(target_n))
    cloud = pred if isinstance(pred, CloudPredictor) else None
    pending: list[tuple[int, np.ndarray]] = []
    rec: dict[str, list[np.ndarray]] = {}
    for k in range(int(round(duration_s / TICK_S))):
        s = plant.read()
        enc, pot = sensor_hook(k, s.enc, s.pot) if sensor_hook else (s.enc, s.pot)
        f_n = target(k)
        if cloud is not None:
            pending = _cloud(cloud, ctrl, pending, k, enc, pot, f_n)
        out = ctrl.step(enc, pot, np.full(enc.shape, q16(f_n), dtype=np.int64))
        _record(rec, k, s, plant, ctrl, out, enc, pot, f_n)
        for _ in range(PLANT_STEPS_PER_TICK):
            plant.step(out / 1000.0)
    return {k: np.array(v) for k, v in rec.items()}


def _cloud(
    cloud: CloudPredictor, ctrl, pending: list[tuple[int, np.ndarray]], k: int, enc, pot, f_n: float
) -> list[tuple[int, np.ndarray]]:
    """Request a prediction every refresh period; deliver those whose latency has passed."""
    if k % max(int(round(1.0 / (cloud.refresh_hz * TICK_S))), 1) == 0:
        mm = np.asarray(cloud.fn(enc, pot, np.full(enc.shape, f_n)), dtype=float)
        pending.append((k + int(round(cloud.latency_s / TICK_S)), np.rint(mm * 65536.0).astype(np.int64)))
    due = [p for p in pending if p[0] <= k]
    for _, d in due:
        ctrl.set_desired(d)
    return [p for p in pending if p[0] > k]


def _record(rec, k: int, s, plant: Plant, ctrl, out: np.ndarray, enc, pot, f_n: float) -> None:
    """Append this tick's sensors (as seen by the controller), controller fields and plant state."""
    row = {f: getattr(s, f) for f in SENSOR_FIELDS}
    row.update(
        enc=enc, pot=pot, out_mv=out, target_n=np.full(enc.shape, f_n), t_s=np.full(enc.shape, k * TICK_S)
    )
    row.update({f: ctrl.field(f) for f in CTRL_FIELDS})
    row.update({f: getattr(plant, f) for f in PLANT_FIELDS})
    for name, v in row.items():
        rec.setdefault(name, []).append(np.array(v, copy=True))
