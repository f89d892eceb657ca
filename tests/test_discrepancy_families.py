"""Benchmark families (issue 14 item 5): fixed expectations, real departures from the base, mis-set bases."""

from __future__ import annotations

import pytest

from seagen.discrepancy.bench import measure
from seagen.discrepancy.families import FAMILIES, family_case, misset_case
from seagen.discrepancy.residuals import noise_sigma, rms
from seagen.discrepancy.workflow import _residual
from seagen.plant.config import CATALOGUE


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_family_departs_from_its_base_and_expects_catalogue_names(name: str) -> None:
    """Each family's data differ from its base by more than the noise, and what it should be named as is
    a fixed set of catalogue effects (<1 s each)."""
    fam = FAMILIES[name]
    assert fam.expected and fam.expected <= set(CATALOGUE)
    cls, truth, base, params = family_case(name, 1)
    bounds = fam.bounds()  # the ranges in the plant's units (pot counts: shares of the pot's full scale)
    assert set(params) == set(fam.ranges) and all(lo <= params[k] <= hi for k, (lo, hi) in bounds.items())
    runs = measure(truth, seed=1, fast=True, plant_cls=cls)
    assert rms(_residual(base, runs, noise_sigma(runs))) > 1.05


def test_misset_base_is_off_by_20_to_60_percent() -> None:
    """A mis-set base has one or two parameters off by 20-60 % of the default plant's values."""
    for seed in range(20):
        _, base, wrong = misset_case(seed)
        assert 1 <= len(wrong) <= 2
        for key, (b, t) in wrong.items():
            e, p = key.split(".")
            assert getattr(base.effect(e), p) == b and 0.2 <= abs(b / t - 1) <= 0.6 + 1e-12, key


def test_families_do_not_call_the_catalogue_laws() -> None:
    """The family module defines its own laws: it names no catalogue effect's parameter of the plant."""
    import inspect

    from seagen.discrepancy import families

    src = inspect.getsource(families).split("FAMILIES: dict")[0]
    assert not any(f"effects.{e}" in src for e in CATALOGUE)
