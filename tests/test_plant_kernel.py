"""The compiled plant motion (plant/kernel.py) against Plant stepped in Python, through the replay."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.discrepancy.bench import make_case
from seagen.discrepancy.candidates import SPACE, Candidate
from seagen.discrepancy.replay import simulate
from seagen.plant import Plant, PlantConfig, kernel

# effects whose laws call arccos, exp or a cube: numpy's vector code and the C library differ in the last bit
TRANSCENDENTAL = ("linkage_friction", "stribeck_friction", "spring_nonlinearity")


def _sets(skip: tuple[str, ...]) -> list[dict]:
    """The unchanged plant, three random points of every other catalogue effect, and one mixed set."""
    rng = np.random.default_rng(0)
    sets: list[dict] = [{}]
    for e in SPACE:
        if e not in skip:
            sets += [Candidate((e,), rng.uniform(0, 1, len(SPACE[e]))).params() for _ in range(3)]
    sets.append(
        {
            "viscous_friction": {"b_n_s_per_mm": 0.1},
            "backlash": {"half_width_mm": 0.05},
            "transport_delay": {"delay_s": 0.0123},
            "pot_voltage_drop": {"counts_per_unit_current": 50.0, "time_constant_s": 0.2},
        }
    )
    return sets


@pytest.fixture(scope="module")
def runs():
    """Four trials of seagen's quick data with a hidden backlash (pushes and retracts, contact)."""
    return make_case(("backlash",), 11, fast=True).runs.take([0, 1, 2, 3])


def test_kernel_equals_python_stepping_bit_for_bit(runs) -> None:
    """Without the laws that call transcendental functions, the compiled motion gives the numbers of Plant
    stepped in Python exactly (every channel and every learned-residual input), on a mixed batch (~3 s)."""
    base = PlantConfig().with_effect("linkage_friction", False)
    sets = _sets(TRANSCENDENTAL)
    got_in: dict = {}
    want_in: dict = {}
    got = simulate(base, sets, runs, got_in)
    want = simulate(base, sets, runs, want_in, compiled=False)
    for c in want:
        assert np.array_equal(got[c], want[c], equal_nan=True), c
    for c in want_in:
        assert np.array_equal(got_in[c], want_in[c], equal_nan=True), c


def test_kernel_agrees_to_rounding_with_every_effect(runs) -> None:
    """With linkage friction, Stribeck friction and a spring nonlinearity too, the two agree to rounding
    (1e-9 relative) on all but a few readings, where a last-bit difference of arccos moved a stick/slip
    instant by a step: there within 1e-5 of the channel's scale (here ~1e-3 pot counts, ~1e-6 N); and an
    element's numbers do not depend on what shares its batch (exactly) (~3 s)."""
    base = PlantConfig().with_effect("spring_nonlinearity", True, k3_n_per_mm3=0.05)
    sets = _sets(())
    got = simulate(base, sets, runs)
    want = simulate(base, sets, runs, compiled=False)
    for c in want:
        scale = np.nanmax(np.abs(want[c]))
        diff = np.nan_to_num(np.abs(got[c] - want[c]))
        assert np.array_equal(np.isnan(got[c]), np.isnan(want[c])), c
        assert diff.max() <= 1e-5 * scale, c
        assert np.count_nonzero(diff > 1e-9 * scale) <= 1e-3 * diff.size, c
    for i in (0, len(sets) // 2, len(sets) - 1):
        alone = simulate(base, [sets[i]], runs)
        for c in alone:
            assert np.array_equal(alone[c][0], got[c][i], equal_nan=True), (i, c)


def test_kernel_refuses_a_plant_with_its_own_laws() -> None:
    """A Plant subclass with another force law (the families, the LuGre session) is stepped in Python."""

    class Other(Plant):
        def friction_limits(self, angle_deg):
            fwd, rev = super().friction_limits(angle_deg)
            return fwd + 1.0, rev + 1.0

    cfg = PlantConfig().with_effect("pot_voltage_drop", False)
    assert kernel.available(Plant(cfg, 12.0))
    assert not kernel.available(Other(cfg, 12.0))
    assert not kernel.available(Plant(PlantConfig(), 12.0))  # a sensor-side effect on: the replay's own
