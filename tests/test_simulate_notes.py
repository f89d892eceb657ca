"""`seagen simulate`'s notes on runs that never settle: held at the command limit, or steady off the band
(the predictor, not the loop; for a surface fit, the design's friction loop it cannot follow)."""

from __future__ import annotations

from pathlib import Path

from seagen.actuator import default_actuator, load_actuator
from seagen.cli.control import limit_notes, offset_notes

MICRO = Path(__file__).resolve().parents[1] / "examples" / "actuators" / "micro_6v.toml"


def _row(settled: int, error: float, final: float | None, at_limit: float) -> dict:
    """A Table II row of ten angles."""
    return {
        "settled": settled,
        "angles": 10,
        "error_avg_n": error,
        "settling_final_s": final,
        "at_limit": at_limit,
    }


def test_a_steady_offset_names_the_predictor_and_for_an_sf_the_friction_loop():
    """micro_6v's SF loop (measured: 1.3-1.5 N off, never at the limit): one note naming the targets, the band
    in mm on its 2 N/mm spring and its 2.7 mm friction loop; the MLP row only the offset; rows that settle,
    never reach a steady level, or sit at the limit get no offset note."""
    act = load_actuator(MICRO)
    table = {
        "ctl_mcu": {
            "5": _row(0, 1.51, 0.95, 0.0),
            "10": _row(0, 1.49, 2.6, 0.0),
            "15": _row(10, 0.1, 4.6, 0.0),
        },
        "mlp_mcu": {"5": _row(3, 0.4, 1.6, 0.1)},
        "slow_mcu": {"5": _row(0, 2.0, None, 0.0)},
        "limit_mcu": {"5": _row(0, 2.0, 3.0, 0.9)},
    }
    notes = offset_notes(table, act, {"ctl_mcu"})
    assert len(notes) == 2, notes
    sf, mlp = notes
    assert "ctl_mcu's runs" in sf and "5 N (1.5 N off), 10 N (1.5 N off)" in sf and "15 N" not in sf
    assert (
        "0.15 mm of compression on the 2 N/mm spring" in sf and "spans 2.7 mm" in sf and "--model mlp" in sf
    )
    assert "mlp_mcu's runs" in mlp and "static map" not in mlp
    assert len(limit_notes(table, act)) == 1  # the limit-bound row has its own note


def test_loops_that_settle_get_no_note():
    """The paper's Table II rows (all settled within the band) print nothing."""
    table = {"sf_mcu": {"5": _row(10, 0.06, 0.2, 0.0), "10": _row(10, 0.04, 0.3, 0.0)}}
    assert offset_notes(table, default_actuator(), {"sf_mcu"}) == []
