"""The serial link to a QEMU board: start the emulator, exchange checked frames with timeouts, stop it.

The board's UART is a QEMU socket chardev connecting to a Unix socket this process listens on. Frames are
the ones of fw/pil_main.c: a start byte, type, actuator count, sequence number, payload and a Fletcher-16
sum. Every way the board can fail (QEMU missing, crashed, silent, a corrupted or rejected frame) raises a
UserError with one line naming it, so the command exits 2.
"""

from __future__ import annotations

import os
import shutil
import socket
import struct
import subprocess
import tempfile
import time
from pathlib import Path

from seagen.errors import UserError
from seagen.pil.firmware import Board

QEMU = "qemu-system-arm"
TO_BOARD, FROM_BOARD = 0xA5, 0x5A
ICOUNT_SHIFT = 7  # one instruction = 128 ns of virtual time: SysTick counts stay below 2^24 per tick
BOOT_TIMEOUT_S = 10.0


def fletcher16(data: bytes) -> int:
    """The frame check of fw/pil_main.c (pil_f16)."""
    a = b = 0
    for x in data:
        a = (a + x) % 255
        b = (b + a) % 255
    return (b << 8) | a


def frame(kind: str, n: int, seq: int, payload: bytes) -> bytes:
    """One host-to-board frame."""
    head = bytes([TO_BOARD, ord(kind), n, seq & 0xFF]) + payload
    return head + struct.pack("<H", fletcher16(head))


def qemu_missing(qemu: str) -> str | None:
    """None if the emulator runs, else how to install it."""
    if shutil.which(qemu) is None:
        return (
            f"{qemu} not found: install QEMU's Arm system emulator "
            "(Debian: apt-get install qemu-system-arm, or `make toolchain` as root)"
        )
    return None


class Link:
    """One QEMU process running a firmware ELF, and its serial link."""

    def __init__(self, elf: Path, board: Board, timeout_s: float = 2.0, qemu: str | None = None) -> None:
        self.qemu = qemu or os.environ.get("SEAGEN_QEMU", QEMU)
        if msg := qemu_missing(self.qemu):
            raise UserError(msg)
        self.board, self.timeout_s, self.seq = board, timeout_s, 0
        self.tmp = Path(tempfile.mkdtemp(prefix="seagen-pil."))
        self.log = self.tmp / "qemu.log"
        path = str(self.tmp / "uart.sock")
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.listener.bind(path)
        self.listener.listen(1)
        cmd = [self.qemu, "-M", board.machine, "-display", "none", "-monitor", "none", "-kernel", str(elf)]
        cmd += ["-semihosting-config", "enable=on,target=native", "-icount", f"shift={ICOUNT_SHIFT}"]
        cmd += ["-chardev", f"socket,id=pil,path={path}", "-serial", "chardev:pil"]
        with open(self.log, "wb") as log:
            self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT)
        self.sock = self._accept()

    def _accept(self) -> socket.socket:
        """Wait for QEMU to connect its UART (or to die trying)."""
        self.listener.settimeout(0.05)
        end = time.monotonic() + BOOT_TIMEOUT_S
        while time.monotonic() < end:
            try:
                conn, _ = self.listener.accept()
                conn.settimeout(self.timeout_s)
                return conn
            except TimeoutError:
                if self.proc.poll() is not None:
                    self._fail("QEMU exited before connecting its UART")
        self._fail(f"QEMU did not connect its UART within {BOOT_TIMEOUT_S:g} s")
        raise AssertionError  # unreachable

    def _fail(self, what: str) -> None:
        """Stop QEMU and raise one line: what happened, QEMU's exit status and its last output line."""
        try:  # a QEMU on its way out: wait for its exit status
            code: int | None = self.proc.wait(timeout=0.5)
        except subprocess.TimeoutExpired:
            code = None
        status = "" if code is None else f" (QEMU exit status {code})"
        last = ""
        if self.log.exists():
            lines = [x for x in self.log.read_text(errors="replace").splitlines() if x.strip()]
            last = f": {lines[-1].strip()}" if lines else ""
        self.close()
        raise UserError(f"{self.board.machine}: {what}{status}{last}")

    def _read(self, n: int, what: str) -> bytes:
        """Exactly n bytes from the board, or a UserError after the timeout / on a closed link."""
        out = b""
        while len(out) < n:
            try:
                chunk = self.sock.recv(n - len(out))
            except TimeoutError:
                self._fail(f"no answer from the board within {self.timeout_s:g} s ({what})")
            except OSError as e:
                self._fail(f"serial link lost ({what}: {e})")
            if not chunk:
                self._fail(f"the board closed the serial link ({what})")
            out += chunk
        return out

    def exchange(self, kind: str, n: int, payload: bytes, reply_len: int, what: str) -> bytes:
        """Send one frame, return the payload of the board's checked reply of `reply_len` bytes."""
        seq = self.seq & 0xFF
        self.seq += 1
        try:
            self.sock.sendall(frame(kind, n, seq, payload))
        except OSError as e:
            self._fail(f"serial link lost ({what}: {e})")
        head = self._read(4, what)
        if head[0] != FROM_BOARD:
            self._fail(f"corrupted frame from the board ({what}: start byte {head[0]:#04x})")
        if head[1] == ord("E"):
            self._read(2, what)
            why = {1: "failed its check", 2: "has an unknown type or size"}.get(head[2], f"error {head[2]}")
            self._fail(f"the board rejected frame {seq} ({what}): it {why}")
        body = self._read(reply_len + 2, what)
        (check,) = struct.unpack("<H", body[-2:])
        if chr(head[1]) != kind or head[3] != seq or check != fletcher16(head + body[:-2]):
            self._fail(f"corrupted frame from the board ({what}: type {head[1]:#04x}, seq {head[3]})")
        return body[:-2]

    def close(self) -> None:
        """Ask the firmware to exit, then stop QEMU (killed if it does not)."""
        if getattr(self, "sock", None) is not None:
            try:  # the firmware answers 'X' and exits through semihosting
                self.sock.settimeout(0.5)
                self.sock.sendall(frame("X", 0, self.seq & 0xFF, b""))
                self.sock.recv(6)
            except OSError:
                pass
            self.sock.close()
            self.sock = None  # type: ignore[assignment]
        self.listener.close()
        if self.proc.poll() is None:
            try:
                self.proc.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)
