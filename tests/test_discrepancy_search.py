"""The batched search: solvers that share replays get the answers they would get alone."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from seagen.discrepancy.bench import measure
from seagen.discrepancy.candidates import polish, start
from seagen.discrepancy.rendezvous import Rendezvous
from seagen.discrepancy.residuals import noise_sigma
from seagen.plant import PlantConfig


def _batches(asks: list[int]) -> list[list[int]]:
    """Run one thread per solver (solver i asks asks[i] times); the solver ids of every served batch."""
    meet, seen = Rendezvous(len(asks)), []

    def solver(i: int) -> None:
        try:
            for k in range(asks[i]):
                assert meet.ask(i, k) == (i, k)
        finally:
            meet.leave(i)

    threads = [threading.Thread(target=solver, args=(i,)) for i in range(len(asks))]
    for t in threads:
        t.start()
    meet.serve(lambda asked: (seen.append([i for i, _ in asked]), [(i, k) for i, k in asked])[1])
    for t in threads:
        t.join()
    return seen


def test_rendezvous_batches_every_waiting_solver_in_index_order() -> None:
    """A batch forms only when every live solver waits: with 3, 1 and 2 requests the batches are always
    [0,1,2], [0,2], [0] whatever the thread timing (run 20 times), each solver gets its own answers."""
    for _ in range(20):
        assert _batches([3, 1, 2]) == [[0, 1, 2], [0, 2], [0]]


def test_rendezvous_failure_reaches_the_caller_and_the_solvers() -> None:
    """An error in the batched evaluation is raised by serve and wakes the waiting solvers (no hang)."""
    meet, errors = Rendezvous(2), []

    def solver(i: int) -> None:
        try:
            meet.ask(i, i)
        except RuntimeError as exc:
            errors.append(exc)
        finally:
            meet.leave(i)

    threads = [threading.Thread(target=solver, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    with pytest.raises(ZeroDivisionError):
        meet.serve(lambda asked: [1 / 0])
    for t in threads:
        t.join(timeout=10)
    assert len(errors) == 2 and not any(t.is_alive() for t in threads)


def test_polishing_together_equals_polishing_alone() -> None:
    """Candidates polished in one batched call end exactly where each ends polished alone (np.array_equal):
    a replay element depends only on its own parameters, not on what shares its batch (~10 s)."""
    base = PlantConfig().with_effect("backlash", False)
    runs = measure(base.with_effect("backlash", True, half_width_mm=0.08), seed=2, fast=True).take([0, 5, 9])
    sig = noise_sigma(runs)

    def fresh():
        return [start(base, "backlash"), start(base, "viscous_friction"), start(base, "actuator_friction")]

    together = fresh()
    polish(base, together, runs, sig, nfev=4)
    for i, c in enumerate(fresh()):
        polish(base, [c], runs, sig, nfev=4)
        assert np.array_equal(c.u, together[i].u) and c.chi2_fit == together[i].chi2_fit
