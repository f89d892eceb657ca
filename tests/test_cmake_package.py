"""The export folder is a CMake package: add_subdirectory + seagen::NAME builds an app whose outputs equal the
numpy reference bit for bit, with one copy of the shared runtime; verify hashes the CMake files; the shipped
toolchain file cross-builds it for a Cortex-M core."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from seagen.defaults import GENERATED
from seagen.export import prepare, write
from seagen.reference import numpy_ref
from seagen.toolchain.equivalence import edge_inputs, random_inputs
from seagen.toolchain.host import STRICT_CFLAGS
from seagen.verify.run import verify
from tests.conftest import run_cli

MODELS = {"cal_mlp": ("mlp_calibration", False), "ctl_mlp": ("mlp_control", True)}
CMAKE = shutil.which("cmake")
needs_cmake = pytest.mark.skipif(CMAKE is None, reason="cmake not found (Debian: apt-get install cmake)")


def _model(prefix: str) -> str:
    """The shipped model file of an export of MODELS."""
    return str(GENERATED / "models" / f"{MODELS[prefix][0]}.pt")


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    """A calibration and a control model (with its controller) exported into one folder, as the firmware
    example does: (folder, {prefix: Export})."""
    fw = tmp_path_factory.mktemp("pkg") / "fw"
    done = {}
    for prefix, (_name, controller) in MODELS.items():
        done[prefix] = prepare(_model(prefix), prefix=prefix, controller=controller, package="sea")
        write(done[prefix], fw)
    return fw, done


def _inputs(qm) -> np.ndarray:
    """A few recorded int16 input vectors: random in and around the calibrated box, and the edges."""
    return np.vstack([random_inputs(qm, 24, seed=3), edge_inputs(len(qm.inputs))]).astype(np.int64)


def _main_c(vectors: dict[str, np.ndarray]) -> str:
    """An app calling each export's NAME_infer on its vectors and printing the integers, one per line."""
    head = ["#include <stdio.h>", *[f'#include "{p}.h"' for p in vectors], ""]
    body = []
    for p, x in vectors.items():
        rows = ",\n".join("    {" + ", ".join(str(int(v)) for v in row) + "}" for row in x)
        head.append(f"static const int16_t {p}_x[{len(x)}][{p.upper()}_N_IN] = {{\n{rows}\n}};")
        body += [
            f"    for (i = 0; i < {len(x)}; i++) {{",
            f"        int16_t y[{p.upper()}_N_OUT];",
            f"        {p}_infer({p}_x[i], y);",
            '        printf("%d\\n", (int)y[0]);',
            "    }",
        ]
    return "\n".join([*head, "", "int main(void)", "{", "    unsigned i;", *body, "    return 0;", "}", ""])


def _app(root: Path, fw: Path, package: str, main_c: str) -> Path:
    """The user's project: CMakeLists.txt adding the export folder and linking seagen::PACKAGE, and main.c."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "main.c").write_text(main_c)
    (root / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.13)\nproject(app C)\n"
        f'add_subdirectory("{fw.as_posix()}" seagen)\n'
        f"add_executable(app main.c)\ntarget_link_libraries(app PRIVATE seagen::{package})\n"
    )
    return root


def _build(src: Path, build: Path, *defs: str) -> None:
    """Configure (ninja if present, else make) and build, with the strict flags of seagen's own builds."""
    gen = ["-G", "Ninja"] if shutil.which("ninja") else []
    flags = " ".join(f for f in STRICT_CFLAGS if not f.startswith(("-std", "-O")))
    cfg = [CMAKE, "-S", str(src), "-B", str(build), *gen, f"-DCMAKE_C_FLAGS={flags}", *defs]
    for cmd in (cfg, [CMAKE, "--build", str(build)]):
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        assert res.returncode == 0, f"{' '.join(map(str, cmd))}:\n{res.stdout[-3000:]}{res.stderr[-3000:]}"


def _archive(build: Path) -> list[str]:
    """The object names in the export folder's static library."""
    lib = next(build.rglob("libseagen_sea.a"))
    ar = shutil.which("ar") or shutil.which("arm-none-eabi-ar")
    return subprocess.run([ar, "t", str(lib)], capture_output=True, text=True, check=True).stdout.split()


@needs_cmake
def test_add_subdirectory_app_equals_the_numpy_reference(exports, tmp_path):
    """add_subdirectory(fw) + target_link_libraries(app seagen::sea): the app's integers == numpy_ref's, and
    the library holds every C file of both exports once (a sources file without its manifest is ignored)."""
    fw, done = exports
    vectors = {p: _inputs(ex.qmodel) for p, ex in done.items()}
    src = _app(tmp_path / "app", fw, "sea", _main_c(vectors))
    (fw / "gone.seagen.cmake").write_text("list(APPEND SEAGEN_SOURCES gone.c)\n")  # no gone.seagen.json
    _build(src, tmp_path / "build")
    out = subprocess.run([str(tmp_path / "build" / "app")], capture_output=True, text=True, check=True)
    got = np.array(out.stdout.split(), dtype=np.int64)
    want = np.concatenate([numpy_ref.infer(done[p].qmodel, x).reshape(-1) for p, x in vectors.items()])
    np.testing.assert_array_equal(got, want)
    objects = _archive(tmp_path / "build")
    sources = {n for ex in done.values() for n in ex.files if n.endswith(".c")}
    assert sorted(objects) == sorted(f"{n}.o" for n in sources), objects


def _emulated(lib: Path, work: Path, roots: tuple[str, ...]):
    """The library linked into a Cortex-M4 image keeping `roots`, on the emulated core."""
    from seagen.toolchain.cortexm import (
        LINKER_SCRIPT,
        Image,
        Machine,
        _symbols,
        cpu_flags,
        data_section,
        flat_section,
        link,
        no_startup_sections,
    )

    work.mkdir()
    (work / "link.ld").write_text(LINKER_SCRIPT)
    elf = link(work, [lib], cpu_flags("cortex-m4"), roots)
    sections = no_startup_sections(elf)
    image = Image(flat_section(elf), _symbols(elf), {}, sections, data_section(elf, sections))
    return Machine(image, "cortex-m4")


@needs_cmake
@pytest.mark.skipif(shutil.which("arm-none-eabi-gcc") is None, reason="arm-none-eabi-gcc not found")
def test_toolchain_file_cross_builds_for_cortex_m4(exports, tmp_path):
    """-DCMAKE_TOOLCHAIN_FILE=fw/arm-none-eabi.cmake: the library and the app are Thumb code for the M4, and
    the library's NAME_infer on the emulated core == numpy_ref bit for bit."""
    pytest.importorskip("unicorn", reason="unicorn (the Cortex-M emulator) is not installed")
    fw, done = exports
    vectors = {p: _inputs(ex.qmodel) for p, ex in done.items()}
    src = _app(tmp_path / "app", fw, "sea", _main_c({p: x[:2] for p, x in vectors.items()}))
    build = tmp_path / "build"
    toolchain = f"-DCMAKE_TOOLCHAIN_FILE={fw / 'arm-none-eabi.cmake'}"
    _build(src, build, toolchain, "-DSEAGEN_CPU=cortex-m4", "-DCMAKE_BUILD_TYPE=Release")
    lib = next(build.rglob("libseagen_sea.a"))
    tags = subprocess.run(["arm-none-eabi-readelf", "-A", str(lib)], capture_output=True, text=True).stdout
    assert tags.count('Tag_CPU_name: "7E-M"') == len(_archive(build)), tags
    syms = subprocess.run(["arm-none-eabi-nm", str(build / "app")], capture_output=True, text=True).stdout
    assert " T cal_mlp_infer" in syms and " T ctl_mlp_infer" in syms
    core = _emulated(lib, tmp_path / "image", tuple(f"{p}_infer" for p in done))
    for p, x in vectors.items():
        got = [core.call(f"{p}_infer", row, np.zeros(1, np.int16))[0][1][0] for row in x.astype(np.int16)]
        want = numpy_ref.infer(done[p].qmodel, x).reshape(-1)
        np.testing.assert_array_equal(np.array(got, dtype=np.int64), want)


def test_verify_hashes_the_cmake_files_and_reexport_restores_them(tmp_path):
    """CMakeLists.txt, NAME.seagen.cmake and the other build systems' files (zephyr/module.yml, library.json,
    the example sketch) are files of the export: verify passes, a hand edit of any is a changed file, and
    re-exporting writes them back in place."""
    fw = tmp_path / "fw"
    write(prepare(_model("cal_mlp"), prefix="cal_mlp"), fw)
    assert verify(str(fw), _model("cal_mlp"), vectors=50).ok
    good = (fw / "CMakeLists.txt").read_text()
    (fw / "CMakeLists.txt").write_text(good.replace("C_STANDARD 99", "C_STANDARD 11"))
    (fw / "cal_mlp.seagen.cmake").write_text("list(APPEND SEAGEN_SOURCES cal_mlp.c)\n")
    others = ("zephyr/module.yml", "library.json", "examples/cal_mlp/cal_mlp.ino")  # the other build systems'
    kept = {n: (fw / n).read_text() for n in others}
    for n in others:
        (fw / n).write_text(kept[n] + "\n")
    bad = verify(str(fw), _model("cal_mlp"), vectors=50)
    failed = {i.name for i in bad.items if not i.ok}
    want = {"CMakeLists.txt unchanged", "cal_mlp.seagen.cmake unchanged", *(f"{n} unchanged" for n in others)}
    assert want <= failed, bad.text()
    code, _out, _err = run_cli("export", _model("cal_mlp"), "--prefix", "cal_mlp", "--out", str(fw))
    assert code == 0 and (fw / "CMakeLists.txt").read_text() == good
    assert {n: (fw / n).read_text() for n in others} == kept
    assert verify(str(fw), _model("cal_mlp"), vectors=50).ok


def test_package_name_and_folder_conflicts_are_one_line_exit_2(exports, tmp_path):
    """A --package that is not a CMake name, or another package than the folder's exports', is refused."""
    fw, _done = exports
    code, _out, err = run_cli("export", _model("cal_mlp"), "--package", "a-b", "--out", str(tmp_path))
    assert code == 2 and "--package" in err and len(err.strip().splitlines()) == 1, err
    code, _out, err = run_cli("export", _model("cal_mlp"), "--prefix", "cal2", "--out", str(fw))
    assert code == 2 and "package 'sea'" in err and len(err.strip().splitlines()) == 1, err
    assert not (fw / "cal2.c").exists()


def _check_c(prefix: str, x: np.ndarray, want: np.ndarray) -> str:
    """A test program: NAME_infer on the recorded rows `x`; exit 1 (naming the row) at the first output that
    differs from `want` (the integer reference's), else 0."""
    rows = ",\n".join("    {" + ", ".join(str(int(v)) for v in row) + "}" for row in x)
    outs = ",\n".join("    {" + ", ".join(str(int(v)) for v in row) + "}" for row in want)
    up = prefix.upper()
    return f"""#include <stdio.h>
#include "{prefix}.h"

static const int16_t x[{len(x)}][{up}_N_IN] = {{
{rows}
}};
static const int16_t want[{len(x)}][{up}_N_OUT] = {{
{outs}
}};

int main(void)
{{
    unsigned i, j;
    for (i = 0; i < {len(x)}u; i++) {{
        int16_t y[{up}_N_OUT];
        {prefix}_infer(x[i], y);
        for (j = 0; j < {up}_N_OUT; j++) {{
            if (y[j] != want[i][j]) {{
                printf("{prefix}: row %u out %u: %d, the reference %d\\n", i, j, (int)y[j], (int)want[i][j]);
                return 1;
            }}
        }}
    }}
    printf("{prefix}: %u rows equal the reference\\n", {len(x)}u);
    return 0;
}}
"""


@needs_cmake
def test_ctest_runs_each_model_on_recorded_vectors_against_the_twins(exports, tmp_path):
    """A firmware project's host build with one ctest per export (add_subdirectory + seagen::sea): each runs
    NAME_infer on recorded rows and checks every output against numpy_ref; ctest passes, and a test whose
    recorded output is off by one fails (the check is not a no-op)."""
    fw, done = exports
    src = tmp_path / "app"
    src.mkdir()
    lines = ["cmake_minimum_required(VERSION 3.13)", "project(app C)", "enable_testing()"]
    lines.append(f'add_subdirectory("{fw.as_posix()}" seagen)')
    for p, ex in done.items():
        x = _inputs(ex.qmodel)
        want = numpy_ref.infer(ex.qmodel, x).reshape(len(x), -1)
        (src / f"check_{p}.c").write_text(_check_c(p, x, want))
        (src / f"wrong_{p}.c").write_text(_check_c(p, x[:3], want[:3] + 1))
        for name in (f"check_{p}", f"wrong_{p}"):
            lines += [
                f"add_executable({name} {name}.c)",
                f"target_link_libraries({name} PRIVATE seagen::sea)",
            ]
            lines.append(f"add_test(NAME {name} COMMAND {name})")
    (src / "CMakeLists.txt").write_text("\n".join(lines) + "\n")
    _build(src, tmp_path / "build")
    ctest = [
        str(Path(CMAKE).with_name("ctest")),
        "--test-dir",
        str(tmp_path / "build"),
        "--output-on-failure",
    ]
    res = subprocess.run([*ctest, "-R", "^check_"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and "100% tests passed" in res.stdout, res.stdout[-3000:]
    res = subprocess.run([*ctest, "-R", "^wrong_"], capture_output=True, text=True, timeout=120)
    assert res.returncode != 0 and "0% tests passed, 2 tests failed" in res.stdout, res.stdout[-3000:]


@needs_cmake
# ~4 s a board (the CMake cross build and the QEMU run): in make test, as issue 37 asks
@pytest.mark.parametrize("core", ["cortex-m0plus", "cortex-m4"])
def test_cmake_built_firmware_closes_the_pil_loop_bit_for_bit(core, tmp_path):
    """The processor-in-the-loop firmware built by CMake from an export folder (add_subdirectory, seagen::sea,
    the folder's arm-none-eabi.cmake for the board's core) runs seagen pil's closed loop on the QEMU board:
    every tick's command, controller state and calibrated force equal the twins'."""
    from seagen.pil.controller import PilController
    from seagen.pil.link import qemu_missing
    from seagen.toolchain.cortexm import toolchain_missing
    from seagen.verify.pil import closed_loop
    from tests.test_pil import ANGLES, twin_cfg

    if msg := toolchain_missing() or qemu_missing("qemu-system-arm"):
        pytest.skip(msg)
    fw = tmp_path / "fw"
    write(
        prepare(str(GENERATED / "models" / "sf_control.pt"), prefix="ctl_sf", controller=True, package="sea"),
        fw,
    )
    cal = prepare(str(GENERATED / "models" / "mlp_calibration.pt"), prefix="cal_mlp", package="sea")
    write(cal, fw)
    board = PilController({}, "ctl_sf", core, "cal_mlp", package=(fw, "sea"))
    try:
        problem, done = closed_loop(board, twin_cfg(), cal.qmodel, ANGLES, 10.0, 60, seed=1)
    finally:
        board.close()
    assert problem is None, problem
    assert done == 60 and len(board.instructions) == 60
