"""Effect parameters at a design's scale (N, mm, N/mm, ...): the discrepancy search's boxes and the plant's
structure defaults follow the design's force range and spring travel; on the paper's actuator nothing
moves."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from seagen.actuator import default_actuator, load_actuator
from seagen.discrepancy.candidates import BOXES, at, box, full_scale, start
from seagen.discrepancy.recalibrate import PLAUSIBLE_SHARES, plausible_range
from seagen.plant import PlantConfig
from seagen.plant.config import DESIGN_UNITS, Effects, design_factor

MICRO = Path(__file__).parents[1] / "examples" / "actuators" / "micro_6v.toml"
FAST = Path(__file__).parents[1] / "examples" / "actuators" / "fast_48v.toml"


def test_the_papers_numbers_are_unchanged():
    """Every factor is exactly 1.0 on the paper's actuator: its default plant and boxes are the paper's."""
    paper = default_actuator()
    assert all(design_factor(e, p, paper) == 1.0 for e, p in DESIGN_UNITS)
    assert PlantConfig().effects == Effects()
    fs = full_scale()
    for e, params in BOXES.items():
        for p in params:
            assert box(e, p, fs, paper) == box(e, p, fs)
    for e, params in PLAUSIBLE_SHARES.items():
        for p in params:
            assert plausible_range(e, p, fs, paper) == plausible_range(e, p, fs)


def test_structure_and_boxes_follow_the_design():
    """On micro_6v (2 N/mm, 20 N) and fast_48v (12 N/mm, 60 N): the structure is as many times stiffer than
    the spring as on the paper's (30 / 4.2), the backlash box scales with the spring's travel at the force
    range, the friction box with the force range; the plant's own friction stays the description's."""
    paper = default_actuator()
    for path in (MICRO, FAST):
        act = load_actuator(path)
        cfg = PlantConfig(actuator=act)
        force = act.control.force_max_n / paper.control.force_max_n
        travel = (act.control.force_max_n / act.stiffness_n_per_mm) / (
            paper.control.force_max_n / paper.stiffness_n_per_mm
        )
        k = cfg.effect("series_compliance").k_n_per_mm
        assert np.isclose(k / act.stiffness_n_per_mm, 30.0 / paper.stiffness_n_per_mm)
        assert cfg.effect("actuator_friction").force_n == 2.7
        fs = full_scale(cfg)
        lo, hi, _ = box("backlash", "half_width_mm", fs, act)
        assert np.isclose(lo, 0.005 * travel) and np.isclose(hi, 0.4 * travel)
        lo, hi, _ = box("actuator_friction", "force_n", fs, act)
        assert np.isclose(lo, 0.2 * force) and np.isclose(hi, 8.0 * force)
        lo, hi = plausible_range("series_compliance", "k_n_per_mm", fs, act)  # the structure's stiffness
        assert lo < k < hi and np.isclose(hi / lo, 150.0 / 8.0)
        c = start(cfg, "series_compliance")  # at the plant's values, in the design's box
        assert np.allclose(
            list(c.params()["series_compliance"].values()),
            list(dataclasses.asdict(cfg.effect("series_compliance")).values())[1:],
        )
        assert 0.0 < c.u[0] < 1.0
        c = at(("backlash",), {"backlash": {"half_width_mm": 0.06 * travel}}, cfg=cfg)
        assert np.isclose(c.params()["backlash"]["half_width_mm"], 0.06 * travel)
