"""A normal (non-editable) build ships templates/ and c_runtime/ in the package (importlib.resources)."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

PROBE = """
import sys
sys.path.insert(0, sys.argv[1])
import seagen
assert seagen.__file__.startswith(sys.argv[1]), seagen.__file__
from seagen.build.runtime import FIXED, runtime_sources
from seagen.codegen.render import environment
assert "sea_rshift_rne_s64" in runtime_sources(*FIXED)["sea_fixed.c"]
assert environment().get_template("model.c.j2")
print("ok")
"""


def test_wheel_carries_templates_and_runtime(tmp_path):
    """The wheel holds seagen/templates/*.j2 and seagen/c_runtime/*; both load from the wheel itself."""
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            str(ROOT),
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path),
        ],
        check=True,
        capture_output=True,
    )
    wheel = next(tmp_path.glob("seagen-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    for f in (
        "seagen/templates/model.c.j2",
        "seagen/templates/model.h.j2",
        "seagen/c_runtime/sea_fixed.c",
        "seagen/c_runtime/sea_nn.h",
        "seagen/c_runtime/README.md",
    ):
        assert f in names, f
    res = subprocess.run(
        [sys.executable, "-c", PROBE, str(wheel)], capture_output=True, text=True, cwd=tmp_path
    )
    assert res.stdout.strip() == "ok", res.stderr
