"""What a seed reproduces on another CPU: the simulator's numbers, bit for bit, whatever SIMD numpy picks.

numpy chooses its vector code (SSE, AVX2, AVX-512) by the CPU; the simulator must not. Each probe runs in
a fresh interpreter with numpy's dispatched features switched off (NPY_DISABLE_CPU_FEATURES) and numba
compiling for a generic x86-64 (NUMBA_CPU_NAME), which is how another machine's CPU is reproduced here.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

# Trials with every effect that calls a transcendental function on (cos/arccos of the linkage angle,
# exp of Stribeck friction, the cube of the spring nonlinearity, tanh/exp of a learned residual, the pot
# drop), their raw rows as CSV text; then the closed loop's settling on the simulated actuator.
PROBE = """
import hashlib, json
from seagen.data.protocol import Move, run_trials
from seagen.plant import PlantConfig
cfg = (PlantConfig().with_effect("stribeck_friction").with_effect("spring_nonlinearity")
       .with_effect("learned_residual", channel="load_cell_n", inputs=["force_n", "speed_mm_s"],
                    scales=[10.0, 5.0], coef=[0.0] + [0.05] * 10))
moves = [Move(a, 3.0, 14.0, -6.0, s) for a, s in ((7.0, 0.0), (15.5, 0.4), (22.0, 0.0), (26.0, 0.3))]
text = "".join(df.to_csv(index=False, float_format="%.17g") for df in run_trials(cfg, moves, seed=5))
print(hashlib.sha256(text.encode()).hexdigest(), len(text))
"""


def _dispatched() -> list[str]:
    """numpy's dispatchable CPU features (those above its baseline)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__

    return list(__cpu_dispatch__)


def _probe(env_extra: dict[str, str]) -> str:
    """PROBE's output in a fresh interpreter with env_extra set."""
    env = {**os.environ, **env_extra}
    res = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    return res.stdout


def test_simulated_trials_are_bit_identical_under_other_cpu_features():
    """The same seed gives the same rows (CSV text at 17 digits, hashed) with numpy's AVX2/AVX-512 paths
    on and off and numba compiling for a generic CPU: a trial's length, every encoder and pot count and
    every force agree exactly, as they must on another x86-64 machine."""
    here = _probe({})
    other = _probe({"NPY_DISABLE_CPU_FEATURES": " ".join(_dispatched()), "NUMBA_CPU_NAME": "generic"})
    assert here == other


def test_the_probe_would_see_numpys_cpu_dependence():
    """The probe can fail: numpy's own exp differs under the two settings on this CPU where it has a
    dispatched exp path (skipped on a CPU with none, e.g. one without AVX2)."""
    code = "import numpy as np; x = np.linspace(-20, 20, 200001); print(hash(np.exp(x).tobytes()))"
    runs = [
        subprocess.run([sys.executable, "-c", code], env={**os.environ, **e}, capture_output=True, text=True)
        for e in ({}, {"NPY_DISABLE_CPU_FEATURES": " ".join(_dispatched())})
    ]
    if runs[0].stdout == runs[1].stdout:
        pytest.skip("numpy's exp is the same with and without its dispatched paths on this CPU")
    assert runs[0].stdout != runs[1].stdout
