"""Every shipped example design (examples/actuators/*.toml) is usable as it stands: it loads, the calibration
protocol reaches its force range in time at a pace that keeps its data small, the generated C holds its
geometry and its gains at its loop rate, its loop rate is a whole number of plant steps, and every number in
it carries its reason (a comment on its line or on its table's header). Fast: no data are simulated here (the
designs' data, training, closed loop and discrepancy figures: docs/discrepancy.md, "Four shipped designs")."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from seagen.actuator import load_actuator
from seagen.data.protocol import sample_every
from seagen.data.reach import pace, reach_problem
from seagen.plant import PlantConfig
from seagen.runtime.actq import act_q
from seagen.runtime.control import ControlConfig

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "actuators"
DESIGNS = sorted(EXAMPLES.glob("*.toml"))
MAX_PACE = 3.0  # the protocol's stretch on a slow design: its data (and the benches on it) grow with it


def test_the_examples_are_there():
    """The three shipped examples (the glob below would pass on an empty folder)."""
    assert {"stiff_24v.toml", "micro_6v.toml", "fast_48v.toml"} <= {p.name for p in DESIGNS}


@pytest.mark.parametrize("path", DESIGNS, ids=[p.stem for p in DESIGNS])
def test_example_design_is_usable(path):
    """Loads and validates; reach_problem None; pace at most MAX_PACE; act_q and the controller's fixed-point
    PID accept it (nothing refused); its loop rate divides the plant's step."""
    act = load_actuator(path)
    assert reach_problem(act) is None
    assert 1.0 <= pace(act) <= MAX_PACE, pace(act)
    ctl = ControlConfig.for_act(act_q(act))
    assert ctl.pid.out_max == min(round(act.control.limit_v * 1000), round(act.motor.supply_v * 1000))
    assert sample_every(PlantConfig(actuator=act)) >= 1


@pytest.mark.parametrize("path", DESIGNS, ids=[p.stem for p in DESIGNS])
def test_every_number_has_its_reason(path):
    """A `key = number` (or array) line has a comment, on itself or on its [table] header line."""
    header_commented = False
    bare = []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith("["):
            header_commented = "#" in line
        elif re.match(r"\s*\w+\s*=\s*[-\d\[]", line) and "#" not in line and not header_commented:
            bare.append(f"{path.name}:{n}: {line.strip()}")
    assert not bare, "\n".join(bare)


def test_the_examples_differ():
    """No two examples are the same design (their hashes differ) or share a name."""
    acts = [load_actuator(p) for p in DESIGNS]
    assert len({a.digest() for a in acts}) == len(acts)
    assert len({a.name for a in acts}) == len(acts)
