"""Issue 39 item 4: batched replays split over worker processes give exactly the serial numbers."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.discrepancy import parallel
from seagen.discrepancy.bench import measure
from seagen.discrepancy.candidates import Candidate, objective, residual_vectors, start
from seagen.discrepancy.parallel import chunked, replays
from seagen.discrepancy.replay import ParamSet
from seagen.discrepancy.residuals import noise_sigma
from seagen.discrepancy.terms import LIBRARY, TERM_SPACE
from seagen.discrepancy.workflow import identify
from seagen.plant import PlantConfig
from seagen.plant.config import CATALOGUE


def _fail_on_negative(sets: list[int]) -> np.ndarray:
    """A chunk function that fails on a negative 'set' (the helpers' error path)."""
    if min(sets) < 0:
        raise ValueError("negative")
    return np.array(sets, dtype=float)[:, None] * 2


def test_a_helper_error_is_raised_and_the_next_batch_is_its_own() -> None:
    """An error in a helper's chunk is raised by the caller; the batch after it gets its own answers."""
    with replays(2):
        with pytest.raises(ValueError, match="negative"):
            chunked(_fail_on_negative, [1, 2, -3, 4])
        assert np.array_equal(chunked(_fail_on_negative, [1, 2, 3, 4, 5])[:, 0], [2, 4, 6, 8, 10])


def _interrupt_here(sets: list[int]) -> np.ndarray:
    """A chunk function interrupted (Ctrl-C) in the caller's own chunk, not in a helper's."""
    if sets[0] == 1:
        raise KeyboardInterrupt
    return np.array(sets, dtype=float)[:, None]


def test_an_interrupt_stops_the_busy_helpers_at_once() -> None:
    """A Ctrl-C in the caller's chunk does not wait for the helpers: they are killed and not used again."""
    with replays(2):
        h = parallel._HELPERS[0]
        with pytest.raises(KeyboardInterrupt):
            chunked(_interrupt_here, [1, 2, 3, 4])
        assert not h.process.is_alive() and not parallel._HELPERS
        assert np.array_equal(chunked(_interrupt_here, [2, 3, 4, 5])[:, 0], [2, 3, 4, 5])


def test_helpers_stop_with_their_block_and_are_killed_by_an_error() -> None:
    """The helpers of a block are gone after it, at once when it ends by an exception."""
    with replays(2):
        procs = [h.process for h in parallel._HELPERS]
        assert len(procs) == 1 and procs[0].is_alive()
    assert not procs[0].is_alive() and not parallel._HELPERS
    with pytest.raises(KeyError), replays(3):
        procs = [h.process for h in parallel._HELPERS]
        raise KeyError("stop")
    assert len(procs) == 2 and not any(p.is_alive() for p in procs)


def test_a_batch_of_every_term_and_effect_is_the_same_over_two_processes() -> None:
    """objective and residual_vectors of a batch (the plant alone, every catalogue effect and every term of
    the library at its start) on two trials: np.array_equal with 1 and with 2 processes."""
    cfg = PlantConfig()
    runs = measure(cfg.with_effect("cell_lag", True, time_constant_s=0.04), seed=3, fast=True).take([0, 9])
    sig = noise_sigma(runs)
    cands = [start(cfg, e) for e in CATALOGUE if e != "pot_noise"]
    cands += [Candidate((t,), np.full(len(TERM_SPACE[t]), 0.3)) for t in LIBRARY]
    sets: list[ParamSet] = [{}] + [c.params() for c in cands]
    jobs = [(c, [c.u, np.clip(c.u + 0.1, 0, 1)]) for c in cands]
    serial = objective(cfg, sets, runs, sig), residual_vectors(cfg, jobs, runs, sig)
    with replays(2):
        split = objective(cfg, sets, runs, sig), residual_vectors(cfg, jobs, runs, sig)
    assert np.array_equal(serial[0], split[0])
    assert all(
        np.array_equal(a, b)
        for x, y in zip(serial[1], split[1], strict=True)
        for a, b in zip(x, y, strict=True)
    )


@pytest.mark.slow
def test_a_discovery_is_the_same_with_one_and_two_processes() -> None:
    """A hidden cell_lag (quick data): the whole identify, discovery included, with 1 and with 2 processes
    gives the same term, the same parameters and 1-sigma (==), the same claim and the same term table."""
    truth = PlantConfig().with_effect("cell_lag", True, time_constant_s=0.04)
    runs = measure(truth, seed=3, fast=True)
    out = []
    for jobs in (1, 2):
        with replays(jobs):
            out.append(identify(runs, PlantConfig()))
    a, b = (r.discovered for r in out)
    assert a is not None and b is not None
    assert (a.term, a.claimed, a.why) == (b.term, b.claimed, b.why)
    assert a.params == b.params and a.sigma == b.sigma and a.with_change == b.with_change
    assert a.table is not None and b.table is not None and a.table.equals(b.table)
    assert (a.rms_before, a.rms_after) == (b.rms_before, b.rms_after)
    assert out[0].verdict == out[1].verdict and out[0].rms_after == out[1].rms_after
