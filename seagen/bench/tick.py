"""The design `seagen bench` measures an export on: its actuator description, the controller `seagen export
--controller` renders for it (templates/bench_tick.c.j2 drives that controller), and a raw enc/pot run
scaled to the design (its compression range in encoder counts, its loop rate's tick).

The run is the paper's on the paper's actuator, exactly: a push of 1,500 counts and back within 0.4 s (40
ticks at 100 Hz) with the pot wandering around 1,800 +- 40 + 3 counts of its 12-bit ADC, a desired force of
8 N. On another design the push spans the same share of its compression range at control.force_max_n
(1.38 ranges), the pot the same shares of its full scale, the desired force the same share of its force
range; the ticks are its loop's, and a push the encoder-jump bound would fault at that pace (a slow drive)
takes more ticks, so every measured tick runs the controller, not its fault latch.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from seagen import __version__
from seagen.actuator import Actuator, default_actuator
from seagen.errors import UserError
from seagen.runtime.actq import act_q
from seagen.runtime.control import MLP_PRED_AVG, ControlConfig, pot_at, q16

PUSH_COUNTS = 1500  # the push on the paper's actuator, encoder counts (1.38 x its 1,086-count range)
PUSH_S = 0.4  # one push and back, s
FORCE_SHARE = 0.4  # the desired force, share of control.force_max_n (8 N of the paper's 20 N)
POT_SHARES = (0.439453125, 0.009765625, 0.000732421875)  # pot mid, wander, ripple: shares of full scale
WANDER_RAD_S, RIPPLE_RAD_S = 100 / 7, 170.0  # their angular rates (1/7 and 1.7 rad per tick at 100 Hz)


@dataclass(frozen=True)
class Run:
    """The raw inputs of consecutive ticks (or NAME_step calls): every `every`-th call is traced."""

    enc: np.ndarray
    pot: np.ndarray
    force_q16: int
    every: int


def range_counts(act: Actuator) -> float:
    """The design's spring compression at control.force_max_n, in encoder counts of nut travel."""
    return act.control.force_max_n / act.stiffness_n_per_mm / act.mm_per_count


def run_of(act: Actuator, traced: int) -> Run:
    """The run on design `act`, about `traced` of its calls traced (all of them on the paper's)."""
    aq = act_q(act)
    push = PUSH_COUNTS * (range_counts(act) / range_counts(default_actuator()))  # 1.0 on the paper's
    # a step of the push is at most push * pi / n counts (+1 for rounding): within the encoder-jump bound
    n = max(round(PUSH_S * act.loop_hz), math.ceil(push * math.pi / max(aq.enc_jump_max - 1, 1)))
    k = np.arange(n)
    t = k / act.loop_hz
    mid, wander, ripple = (pot_at(s, aq.pot_max) for s in POT_SHARES)
    enc = np.rint(push * np.sin(np.pi * k / n) ** 2).astype(np.int64)
    pot = np.rint(mid + wander * np.sin(WANDER_RAD_S * t) + ripple * np.cos(RIPPLE_RAD_S * t))
    force = q16(FORCE_SHARE * act.control.force_max_n)
    return Run(enc, pot.astype(np.int64), force, max(1, math.ceil(n / traced)))


def recorded(d: Path, prefix: str) -> tuple[str, str]:
    """(name, sha256) of the actuator the sea_act_<id>.h that NAME_ACT in NAME.h names records."""
    m = re.search(rf"#define {prefix.upper()}_ACT \(&(sea_act_[a-p]+)\)", (d / f"{prefix}.h").read_text())
    path = d / f"{m.group(1) if m else 'sea_act_'}.h"
    rec = re.search(r"Actuator '(.*)', sha256 ([0-9a-f]{64})", path.read_text()) if path.is_file() else None
    if rec is None:
        raise UserError(f"{d}: {prefix}.h names no actuator file here (sea_act_<id>.h): re-run seagen export")
    return rec.group(1), rec.group(2)


def export_actuator(d: Path, prefix: str, given: Actuator | None) -> Actuator:
    """The description `prefix` in d was exported for (`given`, else the paper's; another sha256: exit 2)."""
    name, digest = recorded(d, prefix)
    act = given or default_actuator()
    if act.digest() != digest:
        was = f"{d}: {prefix} was exported for actuator '{name}' (sha256 {digest[:12]})"
        if given is None:
            raise UserError(f"{was}, not the paper's: give its description with --actuator FILE")
        raise UserError(f"{was}, not for --actuator '{act.name}' (sha256 {act.digest()[:12]})")
    return act


def controller_config(header: str, prefix: str, act: Actuator) -> ControlConfig:
    """The controller `seagen export --controller` renders for this model on `act` (shipped_config)."""
    # the description's gains at its loop rate, its limit within its supply, its force range; an MLP
    # predictor averages MLP_PRED_AVG predictions (the kind is the header summary's 'model:' line)
    m = re.search(r"^ \*\s+model: (\w+) \(", header, re.M)
    if m is None:
        raise UserError(f"{prefix}.h: no 'model:' line in its summary: re-run seagen export")
    return ControlConfig.for_act(act_q(act), **({"pred_avg": MLP_PRED_AVG} if m.group(1) == "mlp" else {}))


def tick_driver(prefix: str, c: ControlConfig) -> dict[str, str]:
    """The controller-tick driver of a control predictor configured with `c` (templates/bench_tick.c.j2)."""
    from seagen.codegen.render import environment

    text = (
        environment()
        .get_template("bench_tick.c.j2")
        .render(
            P=prefix,
            PU=prefix.upper(),
            version=__version__,
            loop_hz=f"{c.act.loop_hz:g}",
            actuator=c.act.name,
            pid=c.pid.as_tuple(),
            predict_every=c.predict_every,
            pred_avg=c.pred_avg,
            force_min=c.force_min,
            force_max=c.force_max,
        )
    )
    return {f"{prefix}_bench.c": text}
