"""Atomic file output: write to a temporary name in the same folder, then rename; a lock for a folder that
several files are renamed into (so two commands writing one folder at once leave one of them, whole)."""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

try:
    import fcntl
except ImportError:  # not POSIX: no folder lock
    fcntl = None  # type: ignore[assignment]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside `path`; rename it onto `path` only if the block succeeds."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f".{p.name}.", suffix=".tmp")
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file ordinary permissions
        os.replace(tmp, p)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


@contextlib.contextmanager
def locked_folder(folder: str | os.PathLike[str]) -> Iterator[Path]:
    """Hold an exclusive lock on `folder` (created if missing) inside the block, waiting for any other
    holder: flock on the folder itself, so nothing is added to it. SIGINT and SIGTERM are held back until
    the block ends (seagen.workers.uninterrupted), so a stop never leaves the renames half done."""
    from seagen.workers import uninterrupted

    p = Path(folder)
    p.mkdir(parents=True, exist_ok=True)
    fd = os.open(p, os.O_RDONLY) if fcntl is not None else None
    try:
        if fd is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX)
            except OSError as e:  # a file system without locks (some network mounts): go on unlocked
                if e.errno not in (errno.ENOLCK, errno.EBADF, errno.EINVAL, errno.EOPNOTSUPP):
                    raise
        with uninterrupted():
            yield p
    finally:
        if fd is not None:
            os.close(fd)  # closing the descriptor releases the lock


def write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write text atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write bytes atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_with(path: str | os.PathLike[str], writer: Callable[[Path], None]) -> None:
    """Let `writer` fill a temporary file, then rename it onto `path`."""
    with atomic_path(path) as tmp:
        writer(tmp)


def writable_place(path: str | os.PathLike[str]) -> str | None:
    """Why `path` cannot be created or replaced (its nearest existing parent is a file, not writable, or
    under /proc or /sys), or None when it can."""
    p = Path(path)
    probe = p.parent if p.exists() else p
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        return f"{probe} is a file, not a folder"
    if not os.access(probe, os.W_OK | os.X_OK) or str(p.resolve()).startswith(("/proc/", "/sys/")):
        return "cannot write there (no permission or not a regular file system)"
    return None
