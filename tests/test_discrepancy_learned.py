"""The learned remainder (issue 14 item 4): a smooth correction where the catalogue has no form."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.data import protocol
from seagen.discrepancy.bench import measure
from seagen.discrepancy.learned import fit_learned, with_learned
from seagen.discrepancy.replay import simulate
from seagen.discrepancy.residuals import noise_floor, noise_sigma, rms, zscores
from seagen.discrepancy.workflow import _residual, split_trials
from seagen.plant import Plant, PlantConfig, load_config, save_config


class SquareLawCellPlant(Plant):
    """A load cell whose gain grows with load (reads tip + 0.015 tip^2): no catalogue effect has this form."""

    def read(self):
        """The plant's reading with the load cell bent."""
        s = super().read()
        tip = self.shaft_force * self.ratio
        s.load_cell_n = s.load_cell_n + 0.015 * tip**2
        s.force_n = s.load_cell_n / self.ratio
        return s


@pytest.fixture(scope="module")
def bent():
    """Quick data from the bent-cell plant, split, with the base's held-out residual."""
    mp = pytest.MonkeyPatch()
    mp.setattr(protocol, "Plant", SquareLawCellPlant)
    runs = measure(PlantConfig(), seed=9, fast=True)
    mp.undo()
    fit_i, held_i = split_trials(runs)
    sig = noise_sigma(runs)
    parts = [runs.take(fit_i), runs.take(held_i)] + [
        {c: s[i] for c, s in sig.items()} for i in (fit_i, held_i)
    ]
    return parts


def test_learned_remainder_closes_the_gap_on_the_channel_it_names(bent) -> None:
    """Fitted on the fitting trials, the correction sits on the load cell, reads the force, and closes at
    least 80 % of the held-out gap to the noise floor (~2 s)."""
    fit, held, sig_f, sig_h = bent
    cfg = PlantConfig()
    before = rms(_residual(cfg, held, sig_h))
    learned = fit_learned(cfg, fit, held, sig_f, sig_h)
    assert learned is not None and learned.channel == "load_cell_n" and "force_n" in learned.inputs
    floor = noise_floor(held, sig_h)
    after = rms(learned.z)
    assert (after - floor) <= 0.2 * (before - floor), (before, after, floor)


def test_learned_residual_in_the_plant_replays_what_was_fitted(bent, tmp_path) -> None:
    """plant.toml carries the learned_residual effect (inputs listed); loaded back and replayed, the plant
    gives exactly the corrected residual the fit reported (~2 s)."""
    fit, held, sig_f, sig_h = bent
    learned = fit_learned(PlantConfig(), fit, held, sig_f, sig_h)
    assert learned is not None
    save_config(with_learned(PlantConfig(), learned), tmp_path / "plant.toml")
    cfg = load_config(tmp_path / "plant.toml")
    assert cfg.on("learned_residual") and cfg.effects.learned_residual.inputs == learned.inputs
    z = zscores(held, simulate(cfg, [{}], held), sig_h)
    for c in ("enc", "pot", "load_cell_n"):
        assert np.allclose(z[c][0][held.mask], learned.z[c][held.mask], rtol=0, atol=1e-9), c


def test_default_plant_has_the_learned_residual_off() -> None:
    """The new effect is off by default, so the default plant (and generated/) is unchanged."""
    assert not PlantConfig().on("learned_residual")
