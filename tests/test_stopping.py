"""Stopping stops and runs do not mix: SIGINT / SIGTERM end every worker with exit 130 / 143 and one line;
exports racing into one folder leave a folder `seagen verify` accepts."""

from __future__ import annotations

import fcntl
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from seagen.atomic import locked_folder
from seagen.cli import main
from seagen.defaults import default_model
from seagen.workers import Terminated, run_in_workers, stop_on_sigterm

# Generous for a loaded 2-core machine; stopping takes ~0.6 s when the machine is busy.
STOP_S = 5.0


@pytest.fixture(autouse=True)
def _ctrl_c_as_at_a_terminal():
    """SIGINT handled as at a terminal while a test runs, whatever this process inherited (a shell starts a
    background job, `make test &`, with SIGINT ignored, and children inherit that) or an earlier test in
    this worker left: else Ctrl-C cannot be tested (the previous disposition is put back afterwards)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def _state(pid: int) -> str | None:
    """The /proc state letter of `pid` (None when it is gone)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def _alive(pid: int) -> bool:
    """`pid` exists and is not a zombie (a dead child nobody has reaped yet)."""
    return _state(pid) not in (None, "Z", "X")


def _children(pid: int) -> list[int]:
    """Live processes whose parent is `pid` (a /proc scan)."""
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                fields = Path(f"/proc/{d}/stat").read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            if int(fields[1]) == pid and fields[0] not in ("Z", "X"):
                out.append(int(d))
    return out


def _start_with_workers(args: list[str], n: int = 2) -> tuple[subprocess.Popen, list[int]]:
    """`seagen ARGS` in its own session, once its `n` workers are running (their pids)."""
    p = subprocess.Popen(
        [sys.executable, "-m", "seagen.cli", *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 60
    while len(kids := _children(p.pid)) < n:
        assert p.poll() is None, p.communicate()[1]
        assert time.monotonic() < deadline, "the workers never started"
        time.sleep(0.05)
    time.sleep(0.5)  # let the workers start their work
    return p, kids


BENCH = ["discrepancy", "bench", "--seeds", "1", "--jobs", "2"]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize(
    ("how", "args", "code", "line"),
    [
        ("SIGTERM", BENCH, 143, "seagen: stopped (SIGTERM)"),  # what `timeout` and CI runners send
        ("SIGINT", [*BENCH, "--families", "--quick"], 130, "seagen: interrupted"),  # Ctrl-C: the group
    ],
)
def test_a_signal_stops_every_worker(how, args, code, line):
    """The bench (plain and --families) stopped by SIGTERM to itself or SIGINT to its process group: exit
    143 / 130 within seconds, exactly one line on stderr, no worker left."""
    p, kids = _start_with_workers(args)
    t0 = time.monotonic()
    if how == "SIGINT":
        os.killpg(p.pid, signal.SIGINT)
    else:
        p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=30)
    took = time.monotonic() - t0
    assert p.returncode == code, err
    assert err.splitlines() == [line], err
    assert took < STOP_S, f"took {took:.1f} s to stop"
    while any(map(_alive, kids)) and time.monotonic() - t0 < STOP_S:
        time.sleep(0.05)
    assert not [k for k in kids if _alive(k)], "workers left running"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc; PR_SET_PDEATHSIG")
def test_workers_die_with_a_killed_parent():
    """SIGKILL to the parent (no handler can run): its workers end within seconds anyway."""
    p, kids = _start_with_workers(BENCH)
    p.kill()
    p.communicate(timeout=30)
    deadline = time.monotonic() + STOP_S
    while any(map(_alive, kids)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [k for k in kids if _alive(k)], "workers outlived their parent"


def _fail_on_two(x: int) -> int:
    """A worker task that fails for one item."""
    if x == 2:
        raise ValueError("two")
    return x * 10


def test_pool_keeps_order_and_an_error_reaches_the_caller():
    """Results come back in order; an error in one task is raised in the caller, in-process or pooled."""
    assert run_in_workers(_fail_on_two, [0, 1, 3], jobs=2) == [0, 10, 30]
    assert run_in_workers(_fail_on_two, [3, 1], jobs=1) == [30, 10]
    with pytest.raises(ValueError, match="two"):
        run_in_workers(_fail_on_two, [0, 1, 2, 3], jobs=2)


@pytest.mark.parametrize(
    ("sig", "raised"), [(signal.SIGTERM, Terminated), (signal.SIGINT, KeyboardInterrupt)]
)
def test_a_stop_waits_for_a_locked_rename(tmp_path, sig, raised):
    """Under stop_on_sigterm SIGTERM raises Terminated (SIGINT KeyboardInterrupt), but not inside
    locked_folder: the block ends first, then the stop takes effect; the handlers are restored."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers run in the main thread only")
    done = []
    with pytest.raises(raised), stop_on_sigterm():
        with locked_folder(tmp_path):
            os.kill(os.getpid(), sig)
            time.sleep(0.05)
            done.append("renamed")
        time.sleep(1)  # the stop takes effect right after the block; never reached
        done.append("after")
    assert done == ["renamed"]
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_export_renames_under_the_folder_lock_and_the_manifest_last(tmp_path, monkeypatch):
    """seagen.export.write: every rename happens while the folder is locked, NAME.seagen.json last."""
    import seagen.export as export

    real, seen = os.replace, []

    def replace(src, dst):
        if Path(dst).parent == tmp_path:  # a rename into the export folder (not e.g. the build cache's)
            fd = os.open(tmp_path, os.O_RDONLY)
            try:
                with pytest.raises(BlockingIOError):
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            finally:
                os.close(fd)
            seen.append(Path(dst).name)
        real(src, dst)

    monkeypatch.setattr(export.os, "replace", replace)
    assert (
        main(["export", str(default_model("sf_calibration")), "--out", str(tmp_path), "--prefix", "k"]) == 0
    )
    assert seen[-1] == "k.seagen.json" and "k.c" in seen
    assert not list(tmp_path.glob(".export.*"))


def test_racing_exports_leave_a_folder_verify_accepts(tmp_path, capsys):
    """Three exports into one folder at once (two prefixes, one of them twice with other weights): each
    prefix verifies afterwards, and nothing staged is left."""
    sf, out = default_model("sf_calibration"), tmp_path / "fw"
    runs = [("a", "int16"), ("c", "int16"), ("c", "int8")]
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "seagen.cli",
                "export",
                str(sf),
                "--out",
                str(out),
                "--prefix",
                p,
                "--weights",
                w,
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        for p, w in runs
    ]
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
    for prefix in ("a", "c"):
        assert main(["verify", str(out), "--model", str(sf), "--prefix", prefix, "--vectors", "200"]) == 0
        capsys.readouterr()
    assert not [f for f in out.iterdir() if f.name.startswith(".")]


def test_sigterm_during_the_renames_lets_the_export_finish_first(tmp_path, monkeypatch, capsys):
    """SIGTERM arriving at the first rename of an export: every file and the manifest are in place, nothing
    staged is left, and then the command stops with 143 and one line."""
    import json

    import seagen.export as export

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers run in the main thread only")
    real = os.replace

    def replace(src, dst):
        if Path(dst).parent == tmp_path and not list(tmp_path.glob("*.c")):
            os.kill(os.getpid(), signal.SIGTERM)
        real(src, dst)

    monkeypatch.setattr(export.os, "replace", replace)
    assert (
        main(["export", str(default_model("sf_calibration")), "--out", str(tmp_path), "--prefix", "k"]) == 143
    )
    assert capsys.readouterr().err.splitlines() == ["seagen: stopped (SIGTERM)"]
    files = json.loads((tmp_path / "k.seagen.json").read_text())["files"]
    on_disk = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file())
    assert on_disk == sorted([*files, "k.seagen.json"])  # the package's zephyr/, examples/k/ included
    assert not list(tmp_path.glob(".export.*"))
