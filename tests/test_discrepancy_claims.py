"""The claim rule (seagen/discrepancy/claims.py, workflow._decide) on small synthetic inputs (fast)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from seagen.discrepancy.claims import (
    CUT,
    OWN,
    Evidence,
    evidence,
    footprints,
    left_structure,
)
from seagen.discrepancy.residuals import channel_rms
from seagen.discrepancy.workflow import Named, _decide

FLOOR = 1.0


def _table(*rows: tuple[str, str, bool]) -> pd.DataFrame:
    """A region table (residuals.region_table's columns) with rows (channel, region, significant)."""
    return pd.DataFrame(
        [("force", region, ch, 100, 0.8, 1.2, 5.0, 1e-6, 1e-5, sig) for ch, region, sig in rows],
        columns=["by", "region", "channel", "n", "mean_z", "rms_z", "t", "p", "p_holm", "significant"],
    )


def _ev(fp, before, after, table=None, without=None) -> Evidence:
    """Evidence with the change undone = before (a single change) unless `without` is given."""
    return evidence(fp, before, after, FLOOR, _table() if table is None else table, without or before)


CH = ("enc", "pot", "load_cell_n")


def _d(enc: float, pot: float, cell: float) -> dict[str, float]:
    return dict(zip(CH, (enc, pot, cell), strict=True))


def test_a_fit_that_closes_the_gap_where_it_acts_is_claimed() -> None:
    """Footprint on the load cell only, which went 12 -> 1.05 sigma (floor 1): claimed; the other channels'
    left gap and structure do not count against it."""
    ev = _ev(_d(0.0, 0.0, 9.0), _d(30.0, 1.0, 12.0), _d(5.0, 1.0, 1.05), _table(("enc", "<1 N", True)))
    assert ev.channels == ["load_cell_n"]
    assert ev.cut == pytest.approx(1 - 0.05 / 11)
    assert ev.ok and ev.words() == ""


def test_a_fit_that_leaves_most_of_the_gap_is_not_claimed() -> None:
    """The channels it acts on went 15 -> 6.4 sigma: closes 61 % < CUT, not claimed, said in words."""
    ev = _ev(_d(0.0, 0.0, 8.3), _d(112.0, 6.0, 15.0), _d(6.7, 1.2, 6.4))
    assert ev.cut == pytest.approx(1 - 5.4 / 14) and ev.cut < CUT
    assert not ev.ok and "closes only 61% of the gap on load_cell_n" in ev.words()


def test_structure_left_where_it_acts_blocks_the_claim() -> None:
    """The gap closed (31.6 -> 1.07 sigma) but a significant region is left on that channel: not claimed."""
    ev = _ev(_d(30.4, 1.8, 1.6), _d(31.6, 2.7, 2.2), _d(1.07, 1.56, 1.34), _table(("enc", "<1 N", True)))
    assert ev.channels == ["enc"] and ev.cut > CUT
    assert not ev.ok and ev.words().startswith("leaves structure on enc (enc by force <1 N")


def test_insignificant_regions_do_not_block_the_claim() -> None:
    """Only significant regions count."""
    ev = _ev(_d(30.4, 0.0, 0.0), _d(31.6, 1.0, 1.0), _d(1.0, 1.0, 1.0), _table(("enc", "<1 N", False)))
    assert ev.ok


def test_channels_acted_on_are_relative_to_the_largest_footprint() -> None:
    """A channel counts when its footprint is >= 30 % of the largest; a change that moves nothing is never
    claimed; a thin change closing a thin gap is; one whose undoing leaves its channel at the floor is not."""
    assert _ev(_d(10.0, 2.9, 3.1), _d(11, 3, 4), _d(1, 1, 1)).channels == ["enc", "load_cell_n"]
    none = _ev(_d(0.0, 0.0, 0.0), _d(5, 5, 5), _d(1, 1, 1))
    assert not none.ok and none.words() == "moves no channel"
    thin = _ev(_d(0.0, 0.1, 0.0), _d(1.0, 1.08, 1.0), _d(1.0, 1.01, 1.0))
    assert thin.channels == ["pot"] and thin.cut == pytest.approx(0.875) and thin.ok
    at_floor = _ev(_d(0.0, 0.1, 0.0), _d(1.0, 0.98, 1.0), _d(1.0, 0.97, 1.0))
    assert at_floor.cut == 1.0 and at_floor.own == 0.0 and not at_floor.ok  # nothing there needs it


def test_left_structure_names_channel_and_region() -> None:
    """Significant rows on the given channels, in words."""
    t = _table(("enc", "<1 N", True), ("pot", "1-5 N", True), ("load_cell_n", ">10 N", False))
    assert left_structure(t, ["enc", "load_cell_n"]) == ["enc by force <1 N, mean +0.80 sigma"]


def test_decide_combines_compensation_edge_and_evidence() -> None:
    """Unexplained: later additions are compensations; the first added is claimed only with evidence; an
    explained case claims every change that has evidence; a fit at the edge of its box is never claimed."""
    good = _ev(_d(0.0, 0.0, 9.0), _d(1, 1, 12), _d(1, 1, 1.0))
    bad = _ev(_d(9.0, 0.0, 0.0), _d(12, 1, 1), _d(6, 1, 1))

    def named() -> list[Named]:
        return [
            Named("actuator_friction", {"force_n": 2.0}, 1.0, {"force_n": 2.7}),
            Named("load_cell_offset", {"offset_n": 0.5}, 1.0),
            Named("spring_preload", {"force_n": 0.3}, 0.95),
        ]

    left = named()
    _decide(left, "unexplained", {"actuator_friction": good, "load_cell_offset": bad, "spring_preload": good})
    assert [n.claimed for n in left] == [False, False, False]
    assert left[0].why.startswith("compensation") and left[1].why.startswith("closest, not claimed: its fit")
    done = named()
    _decide(done, "explained", {"actuator_friction": good, "load_cell_offset": good, "spring_preload": bad})
    assert [n.claimed for n in done] == [True, True, False] and done[0].why == ""
    edge = [Named("viscous_friction", {"b_n_s_per_mm": 0.005}, 1.0)]
    _decide(edge, "explained", {"viscous_friction": good})
    assert not edge[0].claimed and edge[0].edge == ["b_n_s_per_mm"] and "edge" in edge[0].why


def test_footprints_undo_one_change_at_a_time() -> None:
    """On a small run: a load-cell offset moves only the load cell, by |offset| / sigma; a preload moves the
    encoder too; the residual with each undone (one batched replay, ~2 s)."""
    from seagen.discrepancy.bench import measure
    from seagen.discrepancy.residuals import noise_sigma
    from seagen.plant import PlantConfig

    runs = measure(PlantConfig(), seed=1, fast=True).take([0, 1])
    sig = noise_sigma(runs)
    fp, without = footprints(
        PlantConfig(), {"load_cell_offset": {"offset_n": 0.5}, "spring_preload": {"force_n": 1.0}}, runs, sig
    )
    # the data have neither: with the preload undone only the offset is left, which leaves the encoder at
    # its noise; with the offset undone the preload is left, which moves the encoder
    assert without["spring_preload"]["enc"] < 1.5 < without["load_cell_offset"]["enc"]
    cell = 0.5 / sig["load_cell_n"]
    assert fp["load_cell_offset"]["enc"] == 0.0 and fp["load_cell_offset"]["pot"] == 0.0
    assert cell.min() - 1e-6 <= fp["load_cell_offset"]["load_cell_n"] <= cell.max() + 1e-6
    assert fp["spring_preload"]["enc"] > 1.0
    z = {c: np.ones_like(runs.t) * 2.0 for c in CH}
    assert channel_rms(z, runs.mask) == _d(2.0, 2.0, 2.0)


def test_a_rider_on_the_other_changes_is_not_claimed() -> None:
    """A load-cell offset that moves the load cell by 0.07 sigma while the other changes close its gap
    (1.5 -> 1.05 sigma, floor 1; 1.06 with the offset alone undone): the changes close 90 % of the gap and
    leave nothing there, but the offset itself closes 17 % of what is left without it (< OWN): not claimed."""
    ev = _ev(_d(0.0, 0.0, 0.07), _d(8.2, 1.9, 1.5), _d(1.13, 0.97, 1.05), without=_d(1.13, 0.97, 1.06))
    assert ev.cut == pytest.approx(0.9) and not ev.structure
    assert ev.own == pytest.approx(1 / 6) and not ev.ok
    assert "of the gap left on load_cell_n without it" in ev.words()


def test_a_pair_member_sharing_a_channel_is_claimed() -> None:
    """A pot drop beside a viscous friction that also moves the pot: with the pot drop undone the pot is at
    1.55 sigma, with it 0.99 (floor 1): it closes 98 % of that itself: claimed."""
    ev = _ev(_d(0.0, 1.27, 0.0), _d(25.6, 3.9, 2.7), _d(1.0, 0.99, 0.95), without=_d(1.0, 1.55, 0.91))
    assert ev.channels == ["pot"] and ev.own >= OWN and ev.ok


def test_closest_single_is_the_best_single_even_when_a_pair_or_a_joint_wins() -> None:
    """closest_single reads a round's table: the best fit (chi-square on the fitting trials) among single
    catalogue effects (added or recalibrated; the pairs' anchor), not the pair or the joint recalibration
    that won, nor '(none)', whatever their held-out scores."""
    from seagen.discrepancy.workflow import closest_single

    table = pd.DataFrame(
        {
            "candidate": [
                "(none)",
                "spring_preload",
                "series_compliance",
                "spring_preload+backlash",
                "actuator_friction+series_compliance (joint recalibration)",
            ],
            "chi2_fit": [float("nan"), 500.0, 400.0, 300.0, 200.0],
            "bic_held_out": [900.0, 350.0, 400.0, 300.0, 200.0],
        }
    )
    assert closest_single(table) == "series_compliance"
    assert closest_single(table[table["candidate"].str.contains(r"\(|\+")]) is None


def test_headline_and_claims_follow_the_closest_single_change() -> None:
    """The name given first is the closest single change when it is among the changes (a recalibration
    included), else the first added, else the first change; in an unexplained case only that name may be
    claimed."""
    from seagen.discrepancy.workflow import _claims, headline

    assert headline("series_compliance", ["spring_preload", "series_compliance"]) == "series_compliance"
    assert headline("stribeck_friction", ["load_cell_offset", "linkage_friction"]) == "load_cell_offset"
    assert headline("stribeck_friction", []) is None and headline(None, ["backlash"]) == "backlash"
    named = [
        Named("series_compliance", {"k_n_per_mm": 21.0}, 1.0, {"k_n_per_mm": 30.0}),
        Named("spring_preload", {"force_n": 0.3}, 0.96),
    ]
    _claims(named, "unexplained", closest="series_compliance")
    assert [n.claimed for n in named] == [True, False]
    _claims(named, "unexplained", closest="stribeck_friction")  # not among the changes: the first added
    assert [n.claimed for n in named] == [False, True]
