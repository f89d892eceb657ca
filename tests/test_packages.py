"""The export folder is also a Zephyr module, an ESP-IDF component, a PlatformIO library and an Arduino
library: each checked by that system's own parser where one installs from PyPI or Debian (PlatformIO's
manifest schema and `pio pkg pack`, the ESP-IDF component manager's manifest validation, kconfiglib, Debian's
arduino-builder), and the CMake branch Zephyr and ESP-IDF take run by cmake with mocks of their entry
functions (their SDKs cannot be fetched here)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np
import pytest
import yaml

from seagen.codegen.packaging import kconfig_symbol, library_name, sketch_name
from seagen.defaults import GENERATED
from seagen.export import prepare, write

MODELS = {"cal_mlp": ("mlp_calibration", False), "ctl_mlp": ("mlp_control", True)}
PACKAGE = "sea"
CMAKE = shutil.which("cmake")
needs_cmake = pytest.mark.skipif(CMAKE is None, reason="cmake not found (make installs Debian's cmake)")
# Debian's arduino-builder and its AVR core (arduino-core-avr): where they put the hardware and tools folders
ARDUINO_HARDWARE = ("/usr/share/arduino/hardware", "/usr/share/arduino-builder")
ARDUINO_TOOLS = ("/usr/share/arduino-builder", "/usr/bin")
# Debian 12's avr-gcc 5.4 <float.h> defines DECIMAL_DIG for C99 only, which the AVR core's WString.cpp uses
# in C++11: the core (not seagen's C) needs it given
ARDUINO_CORE_FIX = "compiler.cpp.extra_flags=-DDECIMAL_DIG=__DECIMAL_DIG__"
UNO_RAM = 2048


def _model(prefix: str) -> str:
    """The shipped model file of an export of MODELS."""
    return str(GENERATED / "models" / f"{MODELS[prefix][0]}.pt")


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    """A calibration and a control model (with its controller) exported into one package folder:
    (folder, {prefix: Export})."""
    fw = tmp_path_factory.mktemp("pkgs") / "fw"
    done = {}
    for prefix, (_name, controller) in MODELS.items():
        done[prefix] = prepare(_model(prefix), prefix=prefix, controller=controller, package=PACKAGE)
        write(done[prefix], fw)
    return fw, done


def _sources(done) -> list[str]:
    """The C files of every export of the package, once each (the shared runtime once)."""
    return sorted({n for ex in done.values() for n in ex.files if n.endswith(".c")})


def test_package_files_are_written_and_hashed(package):
    """Every build system's files are in the folder, listed in each export's manifest (verify hashes them);
    each export brings its own example sketch."""
    fw, done = package
    for prefix, ex in done.items():
        listed = set(ex.files) | set(ex.tree)
        for name in (
            "zephyr/module.yml",
            "Kconfig",
            "idf_component.yml",
            "library.json",
            "library.properties",
        ):
            assert name in listed and (fw / name).is_file(), name
        assert sketch_name(prefix) in ex.tree and (fw / sketch_name(prefix)).is_file()


def test_platformio_manifests_pass_platformios_own_validation(package, tmp_path):
    """library.json and library.properties through PlatformIO's manifest parser and schema (the ones
    `pio pkg publish` runs), and `pio pkg pack` of the folder, offline; a malformed manifest is refused by
    the same validator (it is not a no-op)."""
    parser = pytest.importorskip("platformio.package.manifest.parser", reason="platformio not installed")
    from platformio.package.manifest.schema import ManifestSchema, ManifestValidationError

    fw, done = package
    for name in ("library.json", "library.properties"):
        data = ManifestSchema().load_manifest(
            parser.ManifestParserFactory.new_from_file(str(fw / name)).as_dict()
        )
        assert data["name"] == library_name(PACKAGE), data
    bad = tmp_path / "library.json"
    bad.write_text((fw / "library.json").read_text().replace('"version": "', '"version": "x.'))
    with pytest.raises(ManifestValidationError):
        ManifestSchema().load_manifest(parser.ManifestParserFactory.new_from_file(str(bad)).as_dict())
    pio = Path(sys.executable).with_name("pio")  # platformio's command, installed beside this Python
    env = {**os.environ, "PLATFORMIO_CORE_DIR": str(tmp_path / "core"), "HOME": str(tmp_path)}
    env["PLATFORMIO_SETTING_ENABLE_TELEMETRY"] = "false"  # offline: nothing sent
    res = subprocess.run(
        [str(pio), "pkg", "pack", str(fw), "-o", str(tmp_path / "p.tar.gz")],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert res.returncode == 0, res.stdout + res.stderr
    with tarfile.open(tmp_path / "p.tar.gz") as tar:
        packed = set(tar.getnames())
    assert {*_sources(done), "library.json", sketch_name("cal_mlp")} <= packed


def test_esp_idf_manifest_passes_the_component_managers_validation(package, tmp_path):
    """idf_component.yml through the ESP-IDF component manager's own manifest validation (upload mode, the
    strictest); a bad version is refused by it."""
    pytest.importorskip("idf_component_tools", reason="idf-component-manager not installed")
    from idf_component_tools.manager import ManifestManager, UploadMode

    fw, _done = package
    name = library_name(PACKAGE)
    assert ManifestManager(fw, name, upload_mode=UploadMode.component).validate().validation_errors == []
    bad = tmp_path / "idf_component.yml"
    bad.write_text((fw / "idf_component.yml").read_text().replace('version: "', 'version: "x.'))
    assert ManifestManager(bad, name, upload_mode=UploadMode.component).validate().validation_errors


# zephyr/module.yml as Zephyr documents it (scripts/zephyr_module.py, its pykwalify schema): the keys a
# module may have, and the type of each key of `build`
ZEPHYR_KEYS = {"name", "build", "tests", "samples", "boards", "blobs"}
ZEPHYR_BUILD = {
    "cmake": str,
    "kconfig": str,
    "cmake-ext": bool,
    "kconfig-ext": bool,
    "sysbuild-cmake": str,
    "sysbuild-kconfig": str,
    "sysbuild-cmake-ext": bool,
    "sysbuild-kconfig-ext": bool,
    "depends": list,
    "settings": dict,
}


def test_zephyr_module_yml_and_kconfig_follow_zephyrs_schema(package):
    """zephyr/module.yml holds only documented keys of the documented types; build.cmake names a folder with
    a CMakeLists.txt and build.kconfig a file, as Zephyr checks; Kconfig parses with kconfiglib (the parser
    Zephyr's build runs) into one bool option CONFIG_SEAGEN_PACKAGE."""
    fw, _done = package
    meta = yaml.safe_load((fw / "zephyr" / "module.yml").read_text())
    assert isinstance(meta, dict) and set(meta) <= ZEPHYR_KEYS, meta
    assert meta["name"] == library_name(PACKAGE)
    build = meta["build"]
    assert set(build) <= set(ZEPHYR_BUILD), build
    assert all(isinstance(v, ZEPHYR_BUILD[k]) for k, v in build.items()), build
    assert (fw / build["cmake"] / "CMakeLists.txt").is_file() and (fw / build["kconfig"]).is_file()
    kconfiglib = pytest.importorskip("kconfiglib", reason="kconfiglib not installed")
    k = kconfiglib.Kconfig(str(fw / build["kconfig"]), warn_to_stderr=False)
    assert not k.warnings, k.warnings
    assert k.syms[kconfig_symbol(PACKAGE)].type == kconfiglib.BOOL


MOCKS = """
function(_log)
  string(JOIN " " line ${ARGN})
  file(APPEND "${LOG}" "${line}\\n")
endfunction()
function(zephyr_library_named name)
  _log(zephyr_library_named ${name})
endfunction()
function(zephyr_library_sources)
  foreach(s IN LISTS ARGN)
    _log(src ${s})
  endforeach()
endfunction()
function(zephyr_include_directories)
  _log(include ${ARGN})
endfunction()
function(idf_component_register)
  cmake_parse_arguments(A "" "" "SRCS;INCLUDE_DIRS;REQUIRES;PRIV_REQUIRES" ${ARGN})
  _log(idf_component_register)
  foreach(s IN LISTS A_SRCS)
    _log(src ${s})
  endforeach()
  _log(include ${A_INCLUDE_DIRS})
endfunction()
"""


def _mock_project(root: Path, fw: Path, log: Path, defs: str) -> Path:
    """A CMake project defining the mocked entry functions and the system's variables, then
    add_subdirectory(fw) as Zephyr and ESP-IDF do with a module or component; it fails if the package
    went on to the plain CMake branch (made its own project and library)."""
    root.mkdir(parents=True)
    (root / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.13)\nproject(mock NONE)\n"
        f'set(LOG "{log.as_posix()}")\n{MOCKS}\n{defs}\n'
        f'add_subdirectory("{fw.as_posix()}" seagen)\n'
        f'if(TARGET seagen_{PACKAGE})\n  message(FATAL_ERROR "the plain CMake branch ran")\nendif()\n'
    )
    return root


def _configure(src: Path, build: Path) -> None:
    res = subprocess.run(
        [CMAKE, "-S", str(src), "-B", str(build)], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]


def _logged(log: Path, fw: Path) -> tuple[list[str], list[str]]:
    """(the calls other than sources, the source file names relative to the folder) of a mock's log."""
    lines = log.read_text().splitlines() if log.exists() else []
    srcs = sorted(Path(s[4:]).relative_to(fw).as_posix() for s in lines if s.startswith("src "))
    return [s for s in lines if not s.startswith("src ")], srcs


@needs_cmake
def test_zephyr_branch_builds_the_library_from_every_export(package, tmp_path):
    """With ZEPHYR_BASE set, CMakeLists.txt calls zephyr_library_named(seagen_PACKAGE) with each C file of
    both exports once and adds the folder to the include path, only when CONFIG_SEAGEN_PACKAGE is set."""
    fw, done = package
    log = tmp_path / "zephyr.log"
    on = f"set(ZEPHYR_BASE /zephyr)\nset(CONFIG_{kconfig_symbol(PACKAGE)} y)"
    _configure(_mock_project(tmp_path / "on", fw, log, on), tmp_path / "b_on")
    calls, srcs = _logged(log, fw)
    assert calls == [f"zephyr_library_named {library_name(PACKAGE)}", f"include {fw.as_posix()}"], calls
    assert srcs == _sources(done)
    off = tmp_path / "off.log"
    _configure(_mock_project(tmp_path / "off", fw, off, "set(ZEPHYR_BASE /zephyr)"), tmp_path / "b_off")
    assert _logged(off, fw) == ([], [])


@needs_cmake
def test_esp_idf_branches_register_the_component(package, tmp_path):
    """ESP-IDF's early requirements pass runs the file as a script (cmake -P, CMAKE_BUILD_EARLY_EXPANSION):
    it registers with no requirements and globs nothing; the build pass (ESP_PLATFORM) registers every C
    file of both exports once with the folder as include directory."""
    fw, done = package
    log = tmp_path / "early.log"
    script = tmp_path / "early.cmake"
    script.write_text(
        f'set(LOG "{log.as_posix()}")\n{MOCKS}\ninclude("{(fw / "CMakeLists.txt").as_posix()}")\n'
    )
    res = subprocess.run(
        [CMAKE, "-DCMAKE_BUILD_EARLY_EXPANSION=1", "-DESP_PLATFORM=1", "-P", str(script)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    assert _logged(log, fw) == (["idf_component_register", "include"], [])
    log = tmp_path / "idf.log"
    _configure(_mock_project(tmp_path / "idf", fw, log, "set(ESP_PLATFORM 1)"), tmp_path / "b_idf")
    calls, srcs = _logged(log, fw)
    assert calls == ["idf_component_register", "include ."], calls
    assert srcs == _sources(done)


def _arduino_missing() -> str | None:
    """Why the Uno build cannot run here, or None."""
    if shutil.which("arduino-builder") is None:
        return "arduino-builder not found (make installs Debian's arduino-builder and arduino-core-avr)"
    if not Path(ARDUINO_HARDWARE[0], "arduino", "avr", "boards.txt").is_file():
        return "the Arduino AVR core is not installed (Debian: arduino-core-avr)"
    return None


@pytest.mark.skipif(_arduino_missing() is not None, reason=str(_arduino_missing()))
def test_arduino_example_compiles_for_an_uno(package, tmp_path):
    """The package folder as an Arduino library (in a libraries folder under its library name): Debian's
    arduino-builder compiles examples/cal_mlp/cal_mlp.ino for an Uno, the library's C with it (every C file
    of the folder), without a warning from seagen's C at -Wall -Wextra; the image fits the Uno's flash."""
    fw, done = package
    libs = tmp_path / "libraries"
    shutil.copytree(fw, libs / library_name(PACKAGE))
    build = tmp_path / "build"
    build.mkdir()
    cmd = ["arduino-builder", "-compile", "-fqbn", "arduino:avr:uno", "-warnings", "all"]
    cmd += [f"-hardware={h}" for h in ARDUINO_HARDWARE] + [f"-tools={t}" for t in ARDUINO_TOOLS]
    cmd += [f"-libraries={libs}", f"-build-path={build}", f"-prefs={ARDUINO_CORE_FIX}"]
    cmd.append(str(libs / library_name(PACKAGE) / sketch_name("cal_mlp")))
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    out = res.stdout + res.stderr
    assert res.returncode == 0, out[-4000:]
    assert (build / "cal_mlp.ino.hex").is_file()
    objects = sorted(p.name for p in (build / "libraries" / library_name(PACKAGE)).glob("*.o"))
    assert objects == [f"{n}.o" for n in _sources(done)], objects
    ours = [ln for ln in out.splitlines() if "warning" in ln and library_name(PACKAGE) in ln]
    assert not ours, ours
    # the builder's own count: the tables are in program memory (SEA_ROM), so RAM is Serial's and the sketch's
    flash, ram = (int(m) for m in re.findall(r"(?:Sketch uses|Global variables use) (\d+) bytes", out))
    print(f"cal_mlp.ino on an Uno: flash {flash} B, RAM {ram} B")
    assert ram <= 1024, out[-2000:]


def test_headers_from_cpp(package, tmp_path):
    """A C++ caller includes every header of the package directly (no extern "C" of its own: the headers
    carry the guard), g++ compiles it warning-free and links it with the package's C built by gcc; its
    cal_mlp_infer outputs equal seagen's integer reference and the controller links and ticks."""
    from seagen.reference import numpy_ref
    from seagen.toolchain.equivalence import edge_inputs

    fw, done = package
    qm = done["cal_mlp"].qmodel
    rows = edge_inputs(len(qm.inputs)).astype(np.int64)
    heads = "".join(f'#include "{h.name}"\n' for h in sorted(fw.glob("*.h")))
    table = ",\n".join("{" + ", ".join(str(int(v)) for v in row) + "}" for row in rows)
    main = f"""{heads}#include <cstdio>
static const int16_t rows[{len(rows)}][CAL_MLP_N_IN] = {{
{table}
}};
int main()
{{
    static ctl_mlp_controller_t ctl;
    for (unsigned i = 0; i < {len(rows)}u; i++) {{
        int16_t y[CAL_MLP_N_OUT];
        cal_mlp_infer(rows[i], y);
        std::printf("%d\\n", static_cast<int>(y[0]));
    }}
    ctl_mlp_controller_init(&ctl, 0, 2048);
    std::printf("%ld\\n", static_cast<long>(ctl_mlp_controller_tick(&ctl, 0, 2048, 0)));
    return 0;
}}
"""
    (tmp_path / "main.cpp").write_text(main)
    objs = []
    for name in _sources(done):
        obj = tmp_path / f"{name}.o"
        cmd = [
            "gcc",
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-I",
            str(fw),
            "-c",
            str(fw / name),
            "-o",
            str(obj),
        ]
        subprocess.run(cmd, check=True, capture_output=True, text=True)
        objs.append(str(obj))
    exe = tmp_path / "app"
    cmd = [
        "g++",
        "-std=c++11",
        "-Wall",
        "-Wextra",
        "-Wpedantic",
        "-Werror",
        "-I",
        str(fw),
        str(tmp_path / "main.cpp"),
    ]
    res = subprocess.run([*cmd, *objs, "-o", str(exe)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr[-3000:]
    out = [
        int(v) for v in subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    ]
    assert len(out) == len(rows) + 1
    np.testing.assert_array_equal(np.array(out[:-1]), numpy_ref.infer(qm, rows).reshape(-1))
