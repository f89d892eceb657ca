"""Batch the requests of several solver threads: answered together once every live solver waits."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any


class Rendezvous:
    """Solvers 0..n-1 each `ask` and wait; `serve` answers all waiting requests in one call, in index order.

    A batch is formed only when every solver still running is waiting, so which requests share a batch
    depends only on the solvers' own progress, never on thread timing (the results are deterministic)."""

    def __init__(self, n: int) -> None:
        self._cond = threading.Condition()
        self._live = set(range(n))
        self._asked: dict[int, Any] = {}
        self._answers: dict[int, Any] = {}
        self._failed = False

    def ask(self, i: int, request: Any) -> Any:
        """Post solver i's request and wait for its answer."""
        with self._cond:
            self._asked[i] = request
            self._cond.notify_all()
            self._cond.wait_for(lambda: i in self._answers or self._failed)
            if self._failed:
                raise RuntimeError("the batched evaluation failed")
            return self._answers.pop(i)

    def leave(self, i: int) -> None:
        """Solver i is done (or failed): batches no longer wait for it."""
        with self._cond:
            self._live.discard(i)
            self._cond.notify_all()

    def serve(self, answer: Callable[[list[tuple[int, Any]]], list[Any]]) -> None:
        """Until every solver has left: answer all requests at once whenever every live solver waits."""
        with self._cond:
            while True:
                self._cond.wait_for(lambda: self._live <= set(self._asked))
                if not self._live:
                    return
                asked = sorted(self._asked.items())
                self._asked.clear()
                try:
                    replies = answer(asked)
                except BaseException:
                    self._failed = True
                    self._cond.notify_all()
                    raise
                self._answers.update({i: r for (i, _), r in zip(asked, replies, strict=True)})
                self._cond.notify_all()
