"""The controller on an emulated board, with the closed loop's controller interface (reset, step,
set_desired, field): every call is one frame to the firmware of seagen/pil/fw running in QEMU."""

from __future__ import annotations

import contextlib
import struct
from pathlib import Path

import numpy as np

from seagen.errors import UserError
from seagen.pil.firmware import board, build_firmware, cmake_firmware, model_header
from seagen.pil.link import Link

REPLY_FIELDS = ("out", "force_est", "desired", "comp", "pot_avg", "fault")
CAL_LOOP_INSTR = 2000  # fw/pil_main.c pil_calibrate: 1,000 x (subs, bne)
MAX_ACTUATORS = 20  # a tick frame (6 + 12 n bytes) fits the firmware's 256-byte receive queue


class PilController:
    """A batch of actuators served by one firmware on one QEMU board (started at the first reset)."""

    def __init__(
        self,
        files: dict[str, str],
        ctl: str,
        core: str,
        cal: str | None = None,
        onboard: bool = True,
        shared: bool = True,
        package: tuple[Path, str] | None = None,
    ) -> None:
        """`shared`: the two models of an actuator read one feature pipeline (pil_model.h's PIL_SHARED);
        `package`: (export folder, PACKAGE): the firmware is built by CMake from the folder, linking
        seagen::PACKAGE (firmware.cmake_firmware), instead of by seagen's compile line from `files`."""
        self.files, self.ctl, self.cal, self.core, self.onboard = files, ctl, cal, core, onboard
        self.package = package
        self.shared = shared
        self.board = board(core)
        self.link: Link | None = None
        self.n = 0
        self.state: dict[str, np.ndarray] = {}
        self.instructions: list[int] = []  # per tick, measured by the firmware (SysTick under -icount)
        self.timeout_s = 2.0

    def _start(self, n: int) -> None:
        """Build the firmware for n actuators, boot it, read its SysTick calibration."""
        if not 1 <= n <= MAX_ACTUATORS:
            raise UserError(f"the firmware serves 1..{MAX_ACTUATORS} actuators, not {n}")
        header = model_header(self.ctl, self.cal, n, self.onboard, self.shared)
        if self.package is None:
            elf = build_firmware(self.files, header, self.core)
        else:
            elf = cmake_firmware(self.package[0], header, self.core, self.package[1])
        self.link = Link(elf, self.board, self.timeout_s)
        empty, loop = struct.unpack("<II", self.link.exchange("C", 0, b"", 8, "calibration"))
        if loop <= empty:
            self.close()
            raise UserError(f"{self.board.machine}: SysTick does not count under -icount ({empty}, {loop})")
        self.empty, self.per_instr = empty, (loop - empty) / CAL_LOOP_INSTR
        self.n = n

    def _frame(self, kind: str, words: list[np.ndarray], what: str) -> None:
        """One frame with int32 columns `words` per actuator; the reply becomes the state."""
        assert self.link is not None
        payload = np.ascontiguousarray(np.stack(words, axis=1).astype("<i4")).tobytes()
        body = self.link.exchange(kind, self.n, payload, 22 * self.n + 4, what)
        rec = np.frombuffer(
            body[:-4],
            dtype=np.dtype([("out", "<i4"), ("force_est", "<i2"), *((f, "<i4") for f in REPLY_FIELDS[2:])]),
        )
        self.state = {f: rec[f].astype(np.int64) for f in REPLY_FIELDS}
        (counts,) = struct.unpack("<I", body[-4:])
        if kind == "T":
            self.instructions.append(int(round((counts - self.empty) / self.per_instr)))

    def reset(self, enc: np.ndarray, pot: np.ndarray) -> None:
        """NAME_controller_init (and the calibration model's reset) for the batch."""
        if self.link is None:
            self._start(len(enc))
        elif len(enc) != self.n:
            raise UserError(f"the firmware serves {self.n} actuators, not {len(enc)}")
        self.ticks = 0
        self._frame("R", [np.asarray(enc), np.asarray(pot)], "reset")

    def step(self, enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
        """One tick on the board: the commands (mV)."""
        f = np.broadcast_to(np.asarray(force_q16), np.shape(enc))
        self._frame("T", [np.asarray(enc), np.asarray(pot), f], f"tick {self.ticks}")
        self.ticks += 1
        return self.state["out"]

    def set_desired(self, desired_q16: np.ndarray) -> None:
        """sea_control_set_desired for the batch (the cloud link's reply)."""
        self._frame("D", [np.asarray(desired_q16)], f"set desired at tick {self.ticks}")

    def field(self, name: str) -> np.ndarray:
        """One int field of the board's state after the last frame."""
        return self.state[name]

    def close(self) -> None:
        """Stop the board."""
        if self.link is not None:
            self.link.close()
            self.link = None

    def __del__(self) -> None:
        with contextlib.suppress(Exception):  # at interpreter exit the modules may be gone
            self.close()
