"""The one worker pool of seagen: processes that stop when the command stops, and SIGTERM as a clean stop.

Every command that starts worker processes uses `run_in_workers`. Its workers ignore SIGINT (a Ctrl-C in
the terminal reaches the whole process group; the parent alone decides), die with the parent
(PR_SET_PDEATHSIG on Linux, and a watchdog on the parent's pid everywhere), and are killed by the parent
as soon as the parent stops for any reason: an exception, Ctrl-C, or SIGTERM once `stop_on_sigterm` has
turned SIGTERM into the exception `Terminated`. The CLI turns those into exit 130 / 143 with one line.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor

WATCHDOG_S = 0.5  # how often a worker checks that its parent is still alive
JOIN_S = 1.0  # how long the parent waits for a killed worker to be gone


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived (raised in the main thread by the handler `stop_on_sigterm` installs)."""

    def __init__(self, signum: int = signal.SIGTERM) -> None:
        super().__init__(signum)
        self.signum = signum


def _raise_terminated(signum: int, _frame: Any) -> None:
    """The SIGTERM handler: stop like a Ctrl-C does, by an exception that unwinds every `finally`."""
    raise Terminated(signum)


@contextlib.contextmanager
def stop_on_sigterm() -> Iterator[None]:
    """Inside the block SIGTERM raises `Terminated` in the main thread (outside it, or off the main
    thread, nothing changes); the previous handler is restored after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def uninterrupted() -> Iterator[None]:
    """SIGINT and SIGTERM held back inside the block (e.g. while renaming files into place): a signal that
    arrives meanwhile takes effect, as it would have, when the block ends. Main thread only (elsewhere the
    block runs unprotected: Python runs signal handlers in the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []

    def hold(signum: int, _frame: Any) -> None:
        pending.append(signum)

    previous: dict[int, Any] = {s: signal.signal(s, hold) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)
        if pending:
            handler = previous[pending[0]]
            if callable(handler):
                handler(pending[0], None)  # raises KeyboardInterrupt / Terminated
            elif handler != signal.SIG_IGN:
                os.kill(os.getpid(), pending[0])  # the default action


def _die_with_parent(parent: int) -> None:
    """Make this process end when `parent` does: PR_SET_PDEATHSIG on Linux, and a watchdog thread."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1 = PR_SET_PDEATHSIG

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(WATCHDOG_S)
        os._exit(1)

    threading.Thread(target=watch, name="seagen-parent-watchdog", daemon=True).start()
    if os.getppid() != parent:  # the parent ended before the above took effect
        os._exit(1)


def _init_worker(parent: int) -> None:
    """Worker start-up: Ctrl-C is the parent's to handle, SIGTERM ends the worker at once, and the worker
    dies with its parent."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent(parent)


def _context() -> multiprocessing.context.BaseContext:
    """fork where the platform has it (workers start at once, nothing is re-imported), else spawn."""
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def _kill(pool: ProcessPoolExecutor) -> None:
    """Kill every worker of `pool` now and wait (briefly) until they are gone; drop the queued work."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # no public accessor before 3.14
    for p in procs:
        with contextlib.suppress(OSError, ValueError):
            p.kill()
    pool.shutdown(wait=False, cancel_futures=True)
    deadline = time.monotonic() + JOIN_S
    for p in procs:
        with contextlib.suppress(OSError, ValueError, AssertionError):
            p.join(max(0.0, deadline - time.monotonic()))


def run_in_workers(
    fn: Callable[[Any], Any], items: Sequence[Any], jobs: int, desc: str = "items", unit: str = "item"
) -> list[Any]:
    """fn(item) for every item, in `jobs` worker processes (in this process when jobs <= 1), results in
    order; a progress bar on stderr when it is a terminal. `fn` and the items must be picklable. If this
    call stops (an error in a worker, Ctrl-C, SIGTERM under `stop_on_sigterm`) every worker is killed
    before the exception goes on."""
    from concurrent.futures import ProcessPoolExecutor

    from tqdm import tqdm

    bar = tqdm(total=len(items), desc=desc, unit=unit, leave=False, disable=None)
    try:
        if jobs <= 1:
            out = []
            for item in items:
                out.append(fn(item))
                bar.update()
            return out
        pool = ProcessPoolExecutor(
            max_workers=jobs, mp_context=_context(), initializer=_init_worker, initargs=(os.getpid(),)
        )
        try:
            futures = [pool.submit(fn, item) for item in items]
            out = []
            for f in futures:
                out.append(f.result())
                bar.update()
        except BaseException:
            with uninterrupted():  # a second Ctrl-C does not cut the clean-up short
                _kill(pool)
            raise
        pool.shutdown(wait=True)
        return out
    finally:
        bar.close()


class Helper:
    """One worker process started now (fork where the platform has it) that runs fn(*args) calls sent to it
    one at a time, for as long as its `helpers` block lasts; it ignores SIGINT and dies with its parent."""

    def __init__(self) -> None:
        ctx = _context()
        self._conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_serve, args=(child, os.getpid()), daemon=True)  # type: ignore[attr-defined]
        self.process.start()
        child.close()

    def submit(self, fn: Callable[..., Any], *args: Any) -> None:
        """Send one call (fn and args must be picklable); its value comes from `result`."""
        self._conn.send((fn, args))

    def result(self) -> Any:
        """The value of the call sent last (its exception raised here)."""
        ok, value = self._conn.recv()
        if not ok:
            raise value
        return value

    def close(self, kill: bool = False) -> None:
        """Stop the process (at once when `kill`) and wait, briefly, until it is gone."""
        with contextlib.suppress(OSError, ValueError, BrokenPipeError):
            if kill:
                self.process.kill()
            else:
                self._conn.send(None)
        self.process.join(JOIN_S)
        if self.process.is_alive():
            with contextlib.suppress(OSError, ValueError):
                self.process.kill()
            self.process.join(JOIN_S)
        self._conn.close()


def _serve(conn: Any, parent: int) -> None:
    """A Helper's loop: run each call received, send back (True, value) or (False, exception)."""
    _init_worker(parent)
    while True:
        try:
            call = conn.recv()
        except EOFError:
            return
        if call is None:
            return
        fn, args = call
        try:
            reply = (True, fn(*args))
        except Exception as exc:  # handed to the parent, which raises it
            reply = (False, exc)
        conn.send(reply)


@contextlib.contextmanager
def helpers(n: int) -> Iterator[list[Helper]]:
    """n Helper processes (none when n <= 0) for the block: started at its entry (before any thread of the
    caller's block exists: a fork then copies one thread), stopped at its end, killed at once if the block
    stops by an exception, Ctrl-C or SIGTERM (under `stop_on_sigterm`)."""
    started: list[Helper] = []
    try:
        for _ in range(max(n, 0)):
            started.append(Helper())
        yield started
    except BaseException:
        with uninterrupted():
            for h in started:
                h.close(kill=True)
        raise
    else:
        for h in started:
            h.close()
