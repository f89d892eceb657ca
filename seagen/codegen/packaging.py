"""The export folder as a package of the firmware build systems beside CMake: a Zephyr module
(zephyr/module.yml, Kconfig), an ESP-IDF component (idf_component.yml), a PlatformIO library (library.json)
and an Arduino library (library.properties, examples/NAME/NAME.ino); CMakeLists.txt (codegen/cmake.py) holds
the Zephyr and ESP-IDF branches."""

from __future__ import annotations

from collections.abc import Sequence

from seagen import __version__
from seagen.codegen.render import environment

SKETCH_VECTORS = 4  # recorded input rows the example sketch checks (small: an Uno has 2 KB of RAM)


def library_name(package: str) -> str:
    """The package's name in every build system: seagen_PACKAGE (the CMake library, the Zephyr module, the
    ESP-IDF component, the PlatformIO and Arduino library)."""
    return f"seagen_{package}"


def kconfig_symbol(package: str) -> str:
    """The Kconfig option that builds the package in Zephyr (CONFIG_ + this name)."""
    return f"SEAGEN_{package.upper()}"


def sketch_name(prefix: str) -> str:
    """The Arduino example of export NAME: examples/NAME/NAME.ino (folder and sketch share the name)."""
    return f"examples/{prefix}/{prefix}.ino"


def shared_files(package: str) -> dict[str, str]:
    """{filename: text} of the package files every export of the folder writes with the same text."""
    env = environment()
    ctx = {"version": __version__, "package": package, "name": library_name(package)}
    ctx["kconfig"] = kconfig_symbol(package)
    return {
        "zephyr/module.yml": env.get_template("zephyr_module.yml.j2").render(ctx),
        "Kconfig": env.get_template("Kconfig.j2").render(ctx),
        "idf_component.yml": env.get_template("idf_component.yml.j2").render(ctx),
        "library.json": env.get_template("library.json.j2").render(ctx),
        "library.properties": env.get_template("library.properties.j2").render(ctx),
    }


def sketch(prefix: str, inputs: Sequence[Sequence[int]], outputs: Sequence[Sequence[int]]) -> dict[str, str]:
    """{examples/NAME/NAME.ino: text}: an Arduino sketch running NAME_infer on recorded int16 input rows and
    printing whether each output equals the recorded one (the integer reference's)."""
    ctx = {"version": __version__, "prefix": prefix, "inputs": inputs, "outputs": outputs}
    return {sketch_name(prefix): environment().get_template("sketch.ino.j2").render(ctx)}
