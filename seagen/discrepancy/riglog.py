"""Rig-style logs from the simulated SEA: a jittered loop on an integer-ms clock, either convention."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seagen.actuator import Actuator, default_actuator
from seagen.data.protocol import Move, _stairs, trial_cap_s
from seagen.plant import Plant, PlantConfig

CONVENTIONS = ("from_row", "up_to_row")  # the command on a row: applied from it on / applied up to it
LOOP_MS = (3, 4, 5)  # a jittered ~250 Hz loop: each period drawn from these (integer ms)


def rig_trials(
    cfg: PlantConfig,
    moves: list[Move],
    seed: int,
    convention: str = "from_row",
    loop_ms: tuple[int, ...] = LOOP_MS,
    max_s: float | None = None,
) -> list[pd.DataFrame]:
    """The moves as a rig loop runs them: each trial samples at its own jittered instants (multiples of the
    plant's 1 ms step), computes the command there and applies it from that instant on; the row logs the
    command it computed (from_row) or the one applied until then (up_to_row). Columns as the schema."""
    if convention not in CONVENTIONS:
        raise ValueError(f"convention must be one of {CONVENTIONS}, got {convention!r}")
    rng = np.random.default_rng(seed + 7919)
    plant = Plant(cfg, np.array([m.angle_deg for m in moves]), seed=seed)
    n = len(moves)
    peak = np.array([m.peak_n for m in moves])
    back = np.array([m.retract_v for m in moves])
    pushing = _stairs(moves, cfg)
    period_ms = int(round(1000.0 / cfg.actuator.loop_hz))  # the protocol's sample period
    step_ms = cfg.dt_s * 1000.0
    phase, quiet = np.zeros(n, dtype=int), np.zeros(n, dtype=int)
    nxt = np.zeros(n, dtype=int)  # plant step of each trial's next sample
    volts = np.zeros(n)
    rows: list[list[tuple]] = [[] for _ in range(n)]
    cap = trial_cap_s(cfg.actuator) if max_s is None else max_s
    for k in range(int(cap / cfg.dt_s)):
        due = (nxt == k) & (phase < 2)
        if due.any():
            s = plant.read()
            phase = np.where(due & (phase == 0) & (s.force_n >= peak), 1, phase)
            quiet = np.where(due, np.where((phase == 1) & (s.force_n < 0.4), quiet + 1, 0), quiet)
            done = due & (phase == 1) & ((quiet >= 25) | (s.enc <= 0))
            push_now = pushing(int(k * step_ms) // period_ms, s.enc, s.force_n)
            new = np.where(phase == 0, push_now, np.where(phase == 1, back, 0.0))
            for i in np.flatnonzero(due):
                logged = new[i] if convention == "from_row" else volts[i]
                rows[i].append(
                    (k * step_ms / 1000.0, logged, s.enc[i], s.pot[i], s.load_cell_n[i], s.force_n[i])
                )
            volts = np.where(due, new, volts)
            phase = np.where(done, 2, phase)
            nxt = np.where(due, k + rng.choice(loop_ms, size=n) / step_ms, nxt).astype(int)
        if (phase == 2).all():
            break
        plant.step(volts)
    out = []
    for j, m in enumerate(moves):
        df = pd.DataFrame(rows[j], columns=["t_s", "motor_v", "enc", "pot", "load_cell_n", "force_n"])
        df.insert(0, "angle_set_deg", m.angle_deg)
        out.append(df.assign(trial=j))
    return out


def rig_csv(
    frames: list[pd.DataFrame], start_ms: int = 12_345, gap_ms: int = 2_000, act: Actuator | None = None
) -> str:
    """The trials as one log a rig writes: integer-ms clock from power-on, gaps between trials, PWM in % of
    the supply of `act` (the paper's when None), pot in mV of its ADC (pot.vref_mv at full scale), forces
    in kgf, angle in rad, an extra column, CRLF line ends, no trial column."""
    act = act or default_actuator()
    parts, t0 = [], start_ms
    for df in frames:
        ms = t0 + np.rint(df["t_s"].to_numpy() * 1000.0).astype(np.int64)
        parts.append(
            pd.DataFrame(
                {
                    "millis": ms,
                    "contact_rad": np.radians(df["angle_set_deg"].to_numpy(float)),
                    "pwm_pct": df["motor_v"].to_numpy(float) / act.motor.supply_v * 100.0,
                    "enc": df["enc"].to_numpy(),
                    "pot_mV": df["pot"].to_numpy(float) * act.pot.vref_mv / float(act.adc_max),
                    "tip_kgf": df["load_cell_n"].to_numpy(float) / 9.80665,
                    "shaft_kgf": df["force_n"].to_numpy(float) / 9.80665,
                    "temp_C": 24.5,
                }
            )
        )
        t0 = int(ms[-1]) + gap_ms
    return pd.concat(parts, ignore_index=True).to_csv(index=False, lineterminator="\r\n", float_format="%.9g")


_RIG_MAP = """\
[columns.t_s]
column = "millis"
unit = "ms"
[columns.angle_set_deg]
column = "contact_rad"
unit = "rad"
[columns.motor_v]
column = "pwm_pct"
unit = "%"
[columns.enc]
column = "enc"
[columns.pot]
column = "pot_mV"
unit = "mV"
full_scale = {vref_mv!r}
[columns.load_cell_n]
column = "tip_kgf"
unit = "kgf"
[columns.force_n]
column = "shaft_kgf"
unit = "kgf"
[trials]
gap_s = 1.0
"""


def rig_map(act: Actuator | None = None) -> str:
    """The `data import` map of rig_csv's log for `act` (the paper's when None): its pot reference in mV."""
    return _RIG_MAP.format(vref_mv=float((act or default_actuator()).pot.vref_mv))


RIG_MAP = rig_map()  # the paper's actuator's
