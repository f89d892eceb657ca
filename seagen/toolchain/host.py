"""Compile C sources on the host: into a cffi module, or into a stand-alone (sanitized) executable.

The project's own C is always compiled by us with the strict C99 flags below — never with Python's
default CFLAGS, which carry -fwrapv and would hide signed-overflow undefined behaviour. Only cffi's glue
is compiled with Python's flags, and it is linked against our object files.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from types import ModuleType

from seagen.errors import UserError

STRICT_CFLAGS = (
    "-std=c99",
    "-O2",
    "-Wall",
    "-Wextra",
    "-Wpedantic",
    "-Wconversion",
    "-Wsign-conversion",
    "-Werror",
)
SANITIZE_FLAGS = (
    "-fsanitize=undefined,address",
    "-fno-sanitize-recover=all",
    "-fno-omit-frame-pointer",
    "-g",
)


class CompileError(UserError):
    """A C file did not compile: its name and the compiler's messages."""

    def __init__(self, source: str, stderr: str) -> None:
        super().__init__(f"C compilation of {source} failed:\n{stderr}")
        self.source, self.stderr = source, stderr


CACHE = Path(os.environ.get("SEAGEN_BUILD_CACHE", Path(tempfile.gettempdir()) / "seagen-cffi"))


def _key(*parts: object) -> str:
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:16]


def _write_sources(srcdir: Path, sources: dict[str, str]) -> list[Path]:
    srcdir.mkdir(parents=True, exist_ok=True)
    for fname, text in sources.items():
        (srcdir / fname).write_text(text)
    return [srcdir / f for f in sources if f.endswith(".c")]


def compile_objects(
    sources: dict[str, str], outdir: Path, extra: tuple[str, ...] = (), *, cc: str = "gcc", pic: bool = True
) -> list[Path]:
    """Compile every .c of `sources` (in order) with `cc` and the strict flags (+ -fPIC) into `outdir`."""
    objs = []
    for c in _write_sources(outdir / "src", sources):
        obj = outdir / (c.stem + ".o")
        fpic = ("-fPIC",) if pic else ()
        cmd = [cc, *STRICT_CFLAGS, *extra, *fpic, "-I", str(c.parent), "-c", str(c), "-o", str(obj)]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            raise CompileError(c.name, res.stderr)
        objs.append(obj)
    return objs


def build(cdef: str, sources: dict[str, str], *, name: str = "seagen_c") -> ModuleType:
    """Build `sources` ({filename: C text}) exposing the declarations `cdef`; return the cffi module.

    The glue only #includes the .h files of `sources`: every function in `cdef` must be declared there.
    """
    import cffi

    modname = f"_{name}_{_key(cdef, sorted(sources.items()), STRICT_CFLAGS)}"
    if modname in sys.modules:
        return sys.modules[modname]
    outdir = CACHE / modname
    built = list(outdir.glob(f"{modname}*.so"))
    if not built:
        CACHE.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(dir=CACHE, prefix=".build."))
        objs = compile_objects(sources, work)
        headers = "".join(f'#include "{f}"\n' for f in sources if f.endswith(".h"))
        ffi = cffi.FFI()
        ffi.cdef(cdef)
        ffi.set_source(
            modname, headers, include_dirs=[str(work / "src")], extra_objects=[str(o) for o in objs]
        )
        so = Path(ffi.compile(tmpdir=str(work), verbose=False))
        outdir.mkdir(parents=True, exist_ok=True)
        os.replace(so, outdir / so.name)
        built = [outdir / so.name]
    loader = importlib.machinery.ExtensionFileLoader(modname, str(built[0]))
    spec = importlib.util.spec_from_file_location(modname, built[0], loader=loader)
    assert spec is not None
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    sys.modules[modname] = mod
    return mod


def build_exe(sources: dict[str, str], *, sanitize: bool = True, name: str = "harness") -> Path:
    """Compile and link `sources` into an executable (UBSan + ASan by default); return its path."""
    flags = SANITIZE_FLAGS if sanitize else ()
    exe = CACHE / f"{name}_{_key(sorted(sources.items()), STRICT_CFLAGS, flags)}"
    if exe.exists():
        return exe
    CACHE.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(dir=CACHE, prefix=".exe."))
    objs = compile_objects(sources, work, flags)
    tmp = work / "a.out"
    res = subprocess.run(["gcc", *flags, *map(str, objs), "-o", str(tmp)], capture_output=True, text=True)
    if res.returncode != 0:
        raise UserError(f"linking {name} failed:\n{res.stderr}")
    os.replace(tmp, exe)
    return exe
