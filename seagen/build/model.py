"""Build a generated model (NAME.c/.h + runtime + test harness) with cffi, or as a sanitized executable."""

from __future__ import annotations

import subprocess
from types import ModuleType

import numpy as np

from seagen import __version__
from seagen.build.host import build, build_exe
from seagen.codegen.render import environment


def harness_source(prefix: str, n_ext: int) -> str:
    """The batch/streaming harness rendered for `prefix` (n_ext < 0: the model has no NAME_step)."""
    return (
        environment()
        .get_template("harness.c.j2")
        .render(P=prefix, PU=prefix.upper(), n_ext=n_ext, version=__version__)
    )


def cdef(prefix: str, step: bool = True) -> str:
    """cffi declarations of the harness entry points."""
    return f"void {prefix}_infer_batch(const int16_t *x, int n, int16_t *y);\n" + (
        f"void {prefix}_step_batch(const int32_t *enc, const int32_t *pot, const int16_t *ext, "
        f"const uint8_t *reset, int n, int16_t *y);\n"
        if step
        else ""
    )


class CModel:
    """The generated C of one model, loaded through cffi."""

    def __init__(self, files: dict[str, str], prefix: str, n_ext: int) -> None:
        sources = dict(files)
        sources[f"{prefix}_harness.c"] = harness_source(prefix, n_ext)
        sources[f"{prefix}_harness.h"] = "#include <stdint.h>\n" + cdef(prefix, n_ext >= 0)
        self.prefix, self.n_ext = prefix, n_ext
        self.mod: ModuleType = build(cdef(prefix, n_ext >= 0), sources, name=prefix)

    def infer(self, x: np.ndarray) -> np.ndarray:
        """NAME_infer on each row of int16 features (N, n_in)."""
        x = np.ascontiguousarray(np.atleast_2d(x), dtype=np.int16)
        y = np.zeros(len(x), dtype=np.int16)
        ffi, lib = self.mod.ffi, self.mod.lib
        getattr(lib, f"{self.prefix}_infer_batch")(
            ffi.from_buffer("int16_t[]", x), len(x), ffi.from_buffer("int16_t[]", y)
        )
        return y.astype(np.int64)

    def step(
        self, enc: np.ndarray, pot: np.ndarray, trial: np.ndarray, ext: np.ndarray | None = None
    ) -> np.ndarray:
        """NAME_step over recorded samples, NAME_reset at every trial start."""
        n = len(enc)
        enc32 = np.ascontiguousarray(enc, dtype=np.int32)
        pot32 = np.ascontiguousarray(pot, dtype=np.int32)
        reset = np.ascontiguousarray(
            np.r_[True, np.asarray(trial)[1:] != np.asarray(trial)[:-1]], dtype=np.uint8
        )
        e = np.ascontiguousarray(np.zeros((n, max(self.n_ext, 1))) if ext is None else ext, dtype=np.int16)
        y = np.zeros(n, dtype=np.int16)
        ffi, lib = self.mod.ffi, self.mod.lib
        getattr(lib, f"{self.prefix}_step_batch")(
            ffi.from_buffer("int32_t[]", enc32),
            ffi.from_buffer("int32_t[]", pot32),
            ffi.from_buffer("int16_t[]", e),
            ffi.from_buffer("uint8_t[]", reset),
            n,
            ffi.from_buffer("int16_t[]", y),
        )
        return y.astype(np.int64)


def sanitized_infer(files: dict[str, str], prefix: str, x: np.ndarray, n_ext: int = 0) -> np.ndarray:
    """Run NAME_infer on rows of x in a UBSan+ASan build (any report aborts: a non-zero exit)."""
    sources = dict(files)
    sources[f"{prefix}_harness.c"] = f"#define {prefix.upper()}_HARNESS_MAIN\n" + harness_source(
        prefix, n_ext
    )
    exe = build_exe(sources, sanitize=True, name=f"{prefix}_asan")
    data = np.ascontiguousarray(np.atleast_2d(x), dtype=np.int16).tobytes()
    res = subprocess.run([str(exe)], input=data, capture_output=True, check=False)
    if res.returncode != 0:
        raise AssertionError(
            f"sanitizer run failed ({res.returncode}):\n{res.stderr.decode(errors='replace')}"
        )
    return np.frombuffer(res.stdout, dtype=np.int16).astype(np.int64)
