"""A normal (non-editable) wheel ships templates, the C runtime and the default models, and runs from them."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from this checkout (no dependencies, no isolation: fast). The build writes build/ and
    *.egg-info in the checkout, so test workers build one at a time (a lock beside their temp folders)."""
    out = tmp_path_factory.mktemp("wheel")
    with open(tmp_path_factory.getbasetemp().parent / "wheel-build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        subprocess.run(
            [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation", "-q"]
            + ["-w", str(out)],
            check=True,
            capture_output=True,
        )
    return next(out.glob("seagen-*.whl"))


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    """The wheel installed with --no-deps into a folder that goes first on the import path."""
    site = tmp_path_factory.mktemp("site")
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site), str(wheel)],
        check=True,
        capture_output=True,
    )
    return site


def seagen_cmd(site: Path, cwd: Path, *args: str, python: str = sys.executable) -> str:
    """Run `seagen ARGS` from the installed wheel in another working directory; returns stdout."""
    env = {**os.environ, "PYTHONPATH": str(site)}
    res = subprocess.run(
        [python, "-m", "seagen.cli", *args], cwd=cwd, env=env, capture_output=True, text=True
    )
    assert res.returncode == 0, f"seagen {' '.join(args)}: {res.stderr[-2000:]}"
    return res.stdout


def test_wheel_carries_templates_runtime_and_defaults(wheel):
    """The wheel holds templates, c_runtime and generated/ (exports and default models) as package data."""
    names = zipfile.ZipFile(wheel).namelist()
    for f in (
        "seagen/templates/model.c.j2",
        "seagen/c_runtime/sea_fixed.c",
        "seagen/c_runtime/sea_nn.h",
        "seagen/c_runtime/README.md",
        "seagen/generated/ctl_sf.h",
        "seagen/generated/cal_mlp.c",
        "seagen/generated/CMakeLists.txt",
        "seagen/generated/cal_mlp.seagen.cmake",
        "seagen/generated/arm-none-eabi.cmake",
        "seagen/templates/CMakeLists.txt.j2",
        "seagen/generated/models/mlp_calibration.pt",
        "seagen/pil/fw/pil_main.c",
        "seagen/pil/fw/pil_board.h",
        "seagen/pil/fw/pil.ld",
    ):
        assert f in names, f
    sources = {f"seagen/{p.relative_to(ROOT / 'seagen')}" for p in (ROOT / "seagen").rglob("*.py")}
    assert not sources - set(names), f"modules missing from the wheel: {sorted(sources - set(names))}"


def test_wheel_runs_simulate_export_and_generate(installed, tmp_path):
    """From the installed wheel, in another folder: simulate --json and export a shipped model (data generate
    from the wheel runs in the slow README-commands test below, ~8 s)."""
    probe = (
        "import seagen; from seagen.defaults import default_model;"
        "print(seagen.__file__, default_model('mlp_calibration'))"
    )
    env = {**os.environ, "PYTHONPATH": str(installed)}
    where = subprocess.run(
        [sys.executable, "-c", probe], cwd=tmp_path, env=env, capture_output=True, text=True, check=True
    ).stdout.split()
    assert all(p.startswith(str(installed)) for p in where), where
    table = json.loads(seagen_cmd(installed, tmp_path, "simulate", "--json", "--config", "sf_mcu"))
    assert table["sf_mcu"]["10"]["settled"] > 0
    seagen_cmd(installed, tmp_path, "export", where[1], "--prefix", "cal_mlp", "--out", "fw")
    assert (tmp_path / "fw" / "cal_mlp.c").read_text() == (ROOT / "generated" / "cal_mlp.c").read_text()


@pytest.mark.slow
def test_wheel_in_a_fresh_virtual_environment(wheel, tmp_path):
    """The wheel with its dependencies in a fresh venv (torch from the local CPU wheel first) runs export."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "-q"]
    subprocess.run([*pip, "torch==2.13.0"], check=True)
    subprocess.run([*pip, str(wheel)], check=True)
    out = subprocess.run(
        [str(venv / "bin" / "seagen"), "simulate", "--json", "--config", "sf_mcu"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert json.loads(out.stdout)["sf_mcu"]["5"]["settled"] > 0


def readme_default_commands() -> list[str]:
    """The `seagen ...` lines of the sh blocks of README.md and every docs/*.md page (in that order, each
    page's blocks in its own order) that name a shipped model (default:NAME)."""
    import re

    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    blocks = [b for page in pages for b in re.findall(r"```sh\n(.*?)```", page.read_text(), re.S)]
    lines = [ln.split("  #")[0].strip() for b in blocks for ln in b.splitlines()]
    return [ln for ln in lines if ln.startswith("seagen ") and "default:" in ln]


@pytest.mark.slow  # ~25 s: every README and docs default: command from the wheel (the fast test runs three)
def test_wheel_lists_models_and_runs_the_readme_default_commands(installed, tmp_path):
    """From the installed wheel: `seagen models` names the shipped files, and every README command that
    uses default:NAME runs (DATA_DIR: a generated data set; --vectors 300, pil --ticks 50, for time)."""
    import re
    import shlex

    rows = json.loads(seagen_cmd(installed, tmp_path, "models", "--json"))
    assert set(rows) == {"default:sf_calibration", "default:mlp_calibration", "default:sf_control"} | {
        "default:mlp_control"
    }
    assert all(Path(r["file"]).is_file() and r["file"].startswith(str(installed)) for r in rows.values())
    commands = readme_default_commands()
    assert len(commands) >= 4, commands
    seagen_cmd(installed, tmp_path, "data", "generate", "--out", "data")
    for line in commands:
        line = re.sub(r"--vectors \d+", "--vectors 300", line).replace("DATA_DIR", "data")
        args = shlex.split(line)[1:]
        if "cortex-m0plus" in args or "cortex-m4" in args:
            pytest.importorskip("unicorn")
            from seagen.toolchain.cortexm import toolchain_missing

            if toolchain_missing():
                continue
        if args[0] == "pil":  # the experiment shortened for time; QEMU is what `make` installs
            if shutil.which("qemu-system-arm") is None:
                continue
            args += ["--ticks", "50", "--actuators", "2"]
        seagen_cmd(installed, tmp_path, *args)


def test_wheel_requires_ranges_and_keeps_the_installed_torch(wheel):
    """The wheel asks for version ranges (torch not pinned) that hold the tested versions, and installing it
    where torch 2.13.0 is present (this venv) installs no torch: pip resolves offline, from what is here."""
    from importlib.metadata import version

    from packaging.requirements import Requirement

    meta = zipfile.ZipFile(wheel).read("seagen-0.1.0.dist-info/METADATA").decode()
    reqs = [
        Requirement(ln.split(":", 1)[1].strip())
        for ln in meta.splitlines()
        if ln.startswith("Requires-Dist:")
    ]
    runtime = {r.name: r for r in reqs if r.marker is None}
    torch = runtime["torch"]
    assert not any(s.operator == "==" for s in torch.specifier), torch
    assert {s.operator for s in torch.specifier} == {">=", "<"}, torch
    for name, req in runtime.items():
        assert req.specifier.contains(version(name).split("+")[0]), f"{name} {version(name)} not in {req}"
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--dry-run",
            "--no-index",
            "--report",
            "-",
            "-q",
            str(wheel),
        ],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    report = json.loads(res.stdout)
    installing = {i["metadata"]["name"].lower() for i in report["install"]}
    assert installing == {"seagen"}, installing
