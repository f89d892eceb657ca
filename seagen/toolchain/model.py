"""The host target: a generated model (NAME.c/.h + runtime + batch driver) built with cffi, or as a
sanitized executable."""

from __future__ import annotations

import subprocess
from types import ModuleType

import numpy as np

from seagen.codegen.runtime import cdef_of
from seagen.ir import QModel
from seagen.toolchain.host import build, build_exe
from seagen.toolchain.target import Target, driver_sources

_CTYPES = {np.dtype(np.int16): "int16_t[]", np.dtype(np.int32): "int32_t[]", np.dtype(np.uint8): "uint8_t[]"}


class CModel(Target):
    """The generated C of one model on the host, loaded through cffi."""

    def __init__(self, files: dict[str, str], prefix: str, qm: QModel) -> None:
        super().__init__(prefix, qm)
        driver = driver_sources(prefix, qm)
        self.mod: ModuleType = build(cdef_of(driver[f"{prefix}_driver.h"]), {**files, **driver}, name=prefix)

    def _call(self, fn: str, *args: int | np.ndarray) -> list[np.ndarray]:
        """NAME_{fn} through cffi; arrays are passed by pointer and written in place."""
        ffi = self.mod.ffi
        c_args = [ffi.from_buffer(_CTYPES[a.dtype], a) if isinstance(a, np.ndarray) else a for a in args]
        getattr(self.mod.lib, f"{self.prefix}_{fn}")(*c_args)
        return [a for a in args if isinstance(a, np.ndarray)]


def sanitized_infer(files: dict[str, str], prefix: str, qm: QModel, x: np.ndarray) -> np.ndarray:
    """Run NAME_infer on rows of x in a UBSan+ASan build (any report aborts: a non-zero exit)."""
    driver = driver_sources(prefix, qm)
    driver[f"{prefix}_driver.c"] = f"#define {prefix.upper()}_DRIVER_MAIN\n" + driver[f"{prefix}_driver.c"]
    exe = build_exe({**files, **driver}, sanitize=True, name=f"{prefix}_asan")
    data = np.ascontiguousarray(np.atleast_2d(x), dtype=np.int16).tobytes()
    res = subprocess.run([str(exe)], input=data, capture_output=True, check=False)
    if res.returncode != 0:
        raise AssertionError(
            f"sanitizer run failed ({res.returncode}):\n{res.stderr.decode(errors='replace')}"
        )
    return np.frombuffer(res.stdout, dtype=np.int16).astype(np.int64)
