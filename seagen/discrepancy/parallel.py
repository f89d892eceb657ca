"""Batched replays split over worker processes: each chunk of parameter sets replayed on its own, in order.

`replays(jobs)` starts jobs - 1 helper processes (seagen.workers.helpers) for a block; inside it, a batch of
parameter sets (candidates.objective, candidates.residual_vectors) is cut into `jobs` contiguous chunks, the
first replayed here and the others by the helpers at the same time, and the chunks' results joined in the
sets' order. Every batch element of a replay is independent of the others (replay.simulate), so the
numbers are those of the whole batch replayed at once, with any number of jobs (test_discover_parallel.py).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from seagen.workers import Helper, helpers

MAX_JOBS = 2  # the default: the machine's cores, at most this many
MIN_CHUNK = 2  # parameter sets per chunk at least (a smaller batch is replayed here alone)
M_TRIM_THRESHOLD, M_MMAP_MAX = -1, -4  # glibc's mallopt parameters (malloc.h)
_HELPERS: list[Helper] = []  # the helpers of the innermost `replays` block (none outside one)


def default_jobs() -> int:
    """The cores this process may use, at most MAX_JOBS."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        cores = os.cpu_count() or 1
    return max(1, min(cores, MAX_JOBS))


def keep_freed_memory() -> None:
    """Have glibc's malloc keep freed memory for reuse (no mmap per large array, no trimming): each replay's
    large arrays otherwise come as fresh pages from the kernel, zeroed and faulted in, and the faults were
    ~15 % of a discovery's CPU (system time). Process-wide, for a command's process; nothing elsewhere."""
    if not sys.platform.startswith("linux"):
        return
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None)
        libc.mallopt(M_MMAP_MAX, 0)
        libc.mallopt(M_TRIM_THRESHOLD, 2**30)


@contextlib.contextmanager
def replays(jobs: int) -> Iterator[None]:
    """Inside the block, batched replays use `jobs` processes (this one and jobs - 1 helpers)."""
    with helpers(jobs - 1) as started:
        previous = _HELPERS[:]
        _HELPERS[:] = started
        try:
            yield
        finally:
            _HELPERS[:] = previous


def chunked(fn: Callable[..., np.ndarray], sets: list, *args: Any) -> np.ndarray:
    """fn(sets, *args) (an array with one row per set) computed in contiguous chunks of sets, the first here
    and each other by a helper at the same time, the rows joined in order. fn must be picklable (a module
    function) and compute each row from its own set alone."""
    k = min(len(_HELPERS) + 1, len(sets) // MIN_CHUNK)
    if k <= 1:
        return fn(sets, *args)
    cuts = np.linspace(0, len(sets), k + 1).round().astype(int)
    busy = _HELPERS[: k - 1]
    for h, a, b in zip(busy, cuts[1:-1], cuts[2:], strict=True):
        h.submit(fn, sets[a:b], *args)
    try:
        parts: list[Any] = [fn(sets[: cuts[1]], *args)]
    except Exception:  # every helper's answer is read, so the next call's answers are its own
        for h in busy:
            _answer(h)
        raise
    except BaseException:  # Ctrl-C or SIGTERM: not waited for, the helpers are stopped at once
        _drop(busy)
        raise
    try:
        answers = [_answer(h) for h in busy]
    except BaseException:
        _drop(busy)
        raise
    for a in answers:
        if isinstance(a, BaseException):
            raise a
    return np.concatenate(parts + answers, axis=0)


def _answer(h: Helper) -> Any:
    """A helper's answer, or the exception it raised."""
    try:
        return h.result()
    except Exception as exc:
        return exc


def _drop(busy: list[Helper]) -> None:
    """Kill helpers whose answers will not be read and use them no more (later batches go without them)."""
    for h in busy:
        h.close(kill=True)
        if h in _HELPERS:
            _HELPERS.remove(h)
