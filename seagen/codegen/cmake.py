"""The export folder as a CMake package: CMakeLists.txt (one static library of every export in the folder, and
the branches Zephyr and ESP-IDF take), NAME.seagen.cmake (an export's C sources) and a toolchain file for
arm-none-eabi-gcc."""

from __future__ import annotations

import re
from pathlib import Path

from seagen import __version__
from seagen.codegen.manifest import SUFFIX, read_manifest
from seagen.codegen.packaging import kconfig_symbol, library_name
from seagen.codegen.render import environment
from seagen.errors import UserError

DEFAULT_PACKAGE = "models"  # the library seagen_models, linked as seagen::models
PACKAGE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")


def sources_name(prefix: str) -> str:
    """The file listing export NAME's C sources (NAME.seagen.cmake)."""
    return f"{prefix}.seagen.cmake"


def check_package(name: str) -> str:
    """The --package NAME, or a UserError: a letter, then letters, digits or _ (at most 64)."""
    if not PACKAGE_NAME.fullmatch(name):
        raise UserError(f"--package must be a letter then letters, digits or _ (at most 64), not {name!r}")
    return name


def cmake_files(prefix: str, files: dict[str, str], package: str) -> dict[str, str]:
    """{filename: text} of the CMake files of an export whose other files are `files`."""
    env, ctx = environment(), {"version": __version__, "package": check_package(package), "prefix": prefix}
    ctx |= {"name": library_name(package), "kconfig": kconfig_symbol(package)}  # the Zephyr branch's names
    sources = sorted(n for n in files if n.endswith(".c"))
    return {
        "CMakeLists.txt": env.get_template("CMakeLists.txt.j2").render(ctx),
        "arm-none-eabi.cmake": env.get_template("arm-none-eabi.cmake.j2").render(ctx),
        sources_name(prefix): env.get_template("sources.cmake.j2").render(ctx, sources=sources),
    }


def check_folder_package(out: Path, prefix: str, package: str) -> None:
    """Refuse (UserError) an export into a folder whose other exports form another CMake package (one
    CMakeLists.txt serves them all); unreadable manifests are left to seagen verify."""
    for path in sorted(out.glob(f"*{SUFFIX}")):
        try:
            man = read_manifest(path)
        except UserError:
            continue
        other = man.data["options"].get("package")
        if man.prefix != prefix and other is not None and other != package:
            raise UserError(
                f"{out}: its export {man.prefix} is in the CMake package '{other}'; export {prefix} with "
                f"--package {other}, or into another folder"
            )
