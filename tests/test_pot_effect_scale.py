"""The effect catalogue's pot parameters (counts of the pot ADC) follow the described pot: their defaults, the
plausible ranges, the benchmark's drawn values and the family ranges are shares of its full scale (exactly the
old counts on the paper's 12-bit pot); a value given in plant.toml stays in counts of that actuator's ADC."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.actuator import actuator_from_dict, default_actuator
from seagen.discrepancy.bench import draw
from seagen.discrepancy.families import family_case
from seagen.discrepancy.recalibrate import PLAUSIBLE, change_lines, plausible, plausible_range
from seagen.plant import PlantConfig, load_config, save_config
from seagen.plant.config import POT_SHARES, config_from_dict, pot_full_scale


def _bits(n: int):
    """The paper's description with an n-bit pot ADC."""
    d = default_actuator().to_dict()
    d["pot"]["adc_bits"] = n
    return actuator_from_dict(d, f"{n}-bit")


def test_paper_numbers_are_the_old_counts_exactly():
    """On the paper's 12-bit pot every scaled number is exactly the old literal (no rounding anywhere)."""
    e = PlantConfig().effects
    assert e.pot_voltage_drop.counts_per_unit_current == 120.0 and e.pot_noise.sigma_counts == 10.0
    assert PLAUSIBLE["pot_voltage_drop"]["counts_per_unit_current"] == (20.0, 400.0)
    assert plausible_range("pot_voltage_drop", "counts_per_unit_current") == (20.0, 400.0)
    old = np.random.default_rng(7).uniform(60.0, 200.0)
    assert draw("pot_voltage_drop", np.random.default_rng(7))["counts_per_unit_current"] == old
    rng = np.random.default_rng(505)
    gain = rng.uniform(80.0, 200.0)
    assert family_case("lagged_pot_bias", 505)[0].gain == gain


@pytest.mark.parametrize("bits", [10, 16])
def test_pot_numbers_scale_with_the_adc(bits, tmp_path):
    """On another ADC the defaults, plausible ranges, drawn truths and family gains are the same shares of
    full scale; a plant.toml value is kept as given and a missing one takes the scaled default."""
    act = _bits(bits)
    k = 2.0 ** (bits - 12)
    assert pot_full_scale(act) == 2.0**bits
    e = PlantConfig(actuator=act).effects
    assert e.pot_voltage_drop.counts_per_unit_current == 120.0 * k and e.pot_noise.sigma_counts == 10.0 * k
    assert e.pot_voltage_drop.time_constant_s == PlantConfig().effects.pot_voltage_drop.time_constant_s
    fs = pot_full_scale(act)
    assert plausible_range("pot_voltage_drop", "counts_per_unit_current", fs) == (20.0 * k, 400.0 * k)
    assert plausible_range("pot_voltage_drop", "time_constant_s", fs) == (0.02, 0.5)
    assert plausible("pot_voltage_drop", "counts_per_unit_current", 410.0 * k, fs) is False
    assert plausible("pot_voltage_drop", "counts_per_unit_current", 390.0 * k, fs) is True
    key = "counts_per_unit_current"
    line = change_lines("pot_voltage_drop", {key: 1.0}, {key: 10.0 * k}, {}, fs)
    assert f"OUTSIDE the plausible range {20 * k:g}..{400 * k:g}" in line[0]
    assert "OUTSIDE" not in change_lines("pot_voltage_drop", {key: 1.0}, {key: 30.0 * k}, {}, fs)[0]
    paper = draw("pot_voltage_drop", np.random.default_rng(3))
    got = draw("pot_voltage_drop", np.random.default_rng(3), act)
    assert got["counts_per_unit_current"] == pytest.approx(paper["counts_per_unit_current"] * k, rel=1e-12)
    assert got["time_constant_s"] == paper["time_constant_s"]
    assert family_case("lagged_pot_bias", 505, act)[0].gain == pytest.approx(
        family_case("lagged_pot_bias", 505)[0].gain * k, rel=1e-12
    )
    cfg = config_from_dict({"effects": {"pot_noise": {"sigma_counts": 3.0}}}, "plant.toml", act)
    assert cfg.effects.pot_noise.sigma_counts == 3.0  # given: counts of this ADC
    assert cfg.effects.pot_voltage_drop.counts_per_unit_current == 120.0 * k  # missing: the scaled default
    save_config(cfg, tmp_path / "plant.toml")
    assert load_config(tmp_path / "plant.toml", act) == cfg


def test_shares_are_exact_binary_fractions():
    """Every share times 2^bits (8..16) is exact, so the paper's counts come out without rounding."""
    for share in POT_SHARES.values():
        assert all((share * 2.0**b) / 2.0**b == share for b in range(8, 17))
        assert (share * 4096.0).is_integer()
