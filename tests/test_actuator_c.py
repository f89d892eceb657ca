"""One actuator description in C: drawn geometries proven (C feature pipeline == twin) or refused; a model's
recorded actuator flows into its export, a disagreeing --actuator is refused; two actuators' exports share
one program."""

from __future__ import annotations

import subprocess
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_sea_features import HEADERS, SANITIZED_MAIN, SOURCES

from seagen.actuator import Actuator, ActuatorError, actuator_from_dict, default_actuator
from seagen.cli import main
from seagen.codegen.runtime import cdef_of, runtime_sources
from seagen.defaults import GENERATED
from seagen.modelfile import load_model, save_model
from seagen.runtime import features as F
from seagen.runtime.actq import ActQ, act_q
from seagen.toolchain.actc import CAct
from seagen.toolchain.host import build, build_exe

I32 = (-(2**31), 2**31 - 1)
N_UNIT = 15  # unit numbers that make one description
CPR = (12, 16, 48, 64, 256, 500, 1024, 2048, 4096, 16384, 65536)  # encoders up to 16 bits per revolution


def _lin(x: float, lo: float, hi: float) -> float:
    return lo + x * (hi - lo)


def _log(x: float, lo: float, hi: float) -> float:
    return float(lo * (hi / lo) ** x)


def description(u: list[float]) -> dict:
    """A plausible linear SEA from N_UNIT numbers in [0, 1]: stiffness, lead, gear ratio, encoder counts,
    CB/CE/home, pot scale/offset/ADC bits 10-16, supply 6-48 V, loop 50-1000 Hz."""
    amin = _lin(u[8], 0.0, 20.0)
    amax = _lin(u[9], amin + 5.0, 85.0)
    return {
        "kind": "linear",
        "name": "drawn",
        "motor": {
            "supply_v": _lin(u[0], 6.0, 48.0),
            "no_load_rpm": _log(u[1], 1000.0, 40000.0),
            "gear_ratio": _log(u[2], 1.0, 1000.0),
            "counts_per_rev": CPR[min(int(u[3] * len(CPR)), len(CPR) - 1)],
            "stall_force_n": 120.0,  # the plant's: no C constant reads them
            "time_constant_s": 0.01,
        },
        "transmission": {"lead_mm": _log(u[4], 0.5, 40.0), "friction_n": 2.7},
        "spring": {"stiffness_n_per_mm": _log(u[5], 0.5, 50.0)},
        "linkage": {
            "cb_mm": _log(u[6], 5.0, 150.0),
            "home_deg": _lin(u[10], amin, amax),
            "angle_min_deg": amin,
            "angle_max_deg": amax,
            "split_deg": (amin + amax) / 2,
            "h_fit": [0.55, 0.032, -0.0031],
            "v_fit_higher": [-0.0009],
        },
        "pot": {
            "full_scale_deg": _log(u[11], 20.0, 340.0),
            "offset_deg": _lin(u[12], -60.0, 60.0),
            "adc_bits": min(10 + int(u[13] * 7), 16),
        },
        "control": {"loop_hz": _log(u[14], 50.0, 1000.0)},
    }


def proven_or_refused(u: list[float]) -> ActQ | None:
    """act_q of the drawn description, or None when refused (one line naming the actuator)."""
    try:
        return act_q(actuator_from_dict(description(u), "drawn"))
    except ActuatorError as e:
        assert "\n" not in str(e) and "'drawn'" in str(e), str(e)
        return None


@pytest.fixture(scope="module")
def c():
    """sea_fixed, sea_nn and sea_features built with the strict flags."""
    return build(cdef_of(*runtime_sources(*HEADERS).values()), runtime_sources(*SOURCES), name="features")


def edge_inputs(a: ActQ, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """enc and pot: int32 extremes, the int32/int64 path limits, the pot rails and table steps, random."""
    k, s = a.enc_i32_bits, a.link_shift
    enc_e = [I32[0], I32[1], 0, -1, 1, -(2**k) - 1, -(2**k), 2**k - 1, 2**k]
    pot_e = [I32[0], I32[1], -1, 0, 1, a.pot_max, a.pot_max + 1, (1 << s) - 1, 1 << s, a.pot_max - (1 << s)]
    enc = np.concatenate([np.repeat(enc_e, len(pot_e)), rng.integers(*I32, 60, endpoint=True)])
    enc = np.concatenate([enc, rng.integers(-(2**k), 2**k, 60)])
    pot = np.concatenate([np.tile(pot_e, len(enc_e)), rng.integers(*I32, 60, endpoint=True)])
    pot = np.concatenate([pot, rng.integers(0, a.pot_max + 1, 60)])
    return enc.astype(np.int64), pot.astype(np.int64)


def c_pipeline(c, a: ActQ, enc: np.ndarray, pot: np.ndarray) -> np.ndarray:
    """(samples, 3 N_BASE + 1): b, d, dd per base signal and the angle, from one run of the C pipeline."""
    ffi, lib = c.ffi, c.lib
    ca = CAct(ffi, a)
    s, f = ffi.new("sea_features_state *"), ffi.new("sea_features_out *")
    lib.sea_features_reset(s)
    rows = []
    for e, p in zip(enc, pot, strict=True):
        lib.sea_features_step(s, ca.ptr, int(e), int(p), f)
        row = []
        for i in range(F.N_BASE):
            row += [f.b[i], lib.sea_features_value(f, F.D, i), lib.sea_features_value(f, F.DD, i)]
        rows.append([*row, lib.sea_features_value(f, F.ANGLE, 0)])
    return np.array(rows, dtype=np.int64)


def twin_pipeline(a: ActQ, enc: np.ndarray, pot: np.ndarray) -> np.ndarray:
    """The same table from the Python twin."""
    b = F.bases_q(a, enc, pot)
    d, dd = F.over_trials(b, np.zeros(len(enc), int))
    cols = [x for i in range(F.N_BASE) for x in (b[i], d[i], dd[i])]
    return np.column_stack([*cols, F.angle_q24(a, pot)])


@settings(
    derandomize=True,
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(st.lists(st.floats(0.0, 1.0), min_size=N_UNIT, max_size=N_UNIT))
def test_drawn_geometry_c_equals_twin_or_refused(c, u):
    """Each drawn geometry is refused with a reason, or its C feature pipeline equals the twin bit for bit on
    int32 extremes, path limits and random counts, with the proven bounds of seagen/runtime/actq.py."""
    a = proven_or_refused(u)
    if a is None:
        return
    assert len(a.link) == 257 and max(abs(v) for v in a.link) < 2**30
    assert a.travel_q << a.enc_i32_bits <= 2**31 and 1 <= a.travel_q < 2**31 and 0 <= a.travel_shift <= 30
    enc, pot = edge_inputs(a, np.random.default_rng(len(a.link) + a.travel_q))
    got, want = c_pipeline(c, a, enc, pot), twin_pipeline(a, enc, pot)
    bad = np.flatnonzero((got != want).any(axis=1))
    assert bad.size == 0, f"sample {bad[0]}: enc {enc[bad[0]]}, pot {pot[bad[0]]}"


def test_at_least_90_percent_of_drawn_geometries_accepted():
    """Of 400 geometries drawn (seeded) over the plausible ranges, at least 90 % are proven, not refused."""
    u = np.random.default_rng(24).random((400, N_UNIT))
    accepted = sum(proven_or_refused(list(row)) is not None for row in u)
    assert accepted >= 0.9 * len(u), f"{accepted} of {len(u)} accepted"


def test_corner_geometries_run_clean_under_sanitizers():
    """The all-low and all-high corners of the ranges (and two mixed ones) run the int32 edge sequence
    under UBSan+ASan without a report and with the twin's values."""
    exe = build_exe({**runtime_sources(*SOURCES), "main.c": SANITIZED_MAIN}, name="features_san")
    corners = [[0.0] * N_UNIT, [1.0] * N_UNIT, [0.0, 1.0] * 7 + [0.0], [1.0, 0.0] * 7 + [1.0]]
    for u in corners:
        a = proven_or_refused(u)
        assert a is not None, u
        enc, pot = edge_inputs(a, np.random.default_rng(7))
        head = " ".join(map(str, a.link)) + "\n" + " ".join(str(v) for _, v in a.struct_fields()) + "\n"
        rows = "\n".join(f"{e} {p} {int(k == 0)}" for k, (e, p) in enumerate(zip(enc, pot, strict=True)))
        res = subprocess.run([str(exe)], input=head + rows, capture_output=True, text=True, check=False)
        assert res.returncode == 0, res.stderr
        got = np.array([line.split() for line in res.stdout.splitlines()], dtype=np.int64)
        assert np.array_equal(got, twin_pipeline(a, enc, pot))


@pytest.mark.parametrize(
    "change,words",
    [
        ({"motor": {"gear_ratio": 1e6, "counts_per_rev": 65536}, "transmission": {"lead_mm": 0.01}}, "Q46"),
        ({"control": {"loop_hz": 5.0}}, "below the 10 Hz"),
        ({"linkage": {"cb_mm": 100000.0}}, "2\\^30"),
    ],
)
def test_geometry_outside_the_formats_is_refused(change, words):
    """A geometry the fixed-point formats cannot hold is refused with the reason, naming the description's
    file (ActuatorError: exit 2)."""
    d = paper_dict()
    for table, fields in change.items():
        d[table].update(fields)
    with pytest.raises(ActuatorError, match=words) as e:
        act_q(actuator_from_dict(d, "odd.toml"))
    assert str(e.value).startswith("odd.toml ('")


def paper_dict() -> dict:
    """The paper's description as parsed TOML."""
    text = resources.files("seagen.actuators").joinpath("paper.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


def second_actuator() -> Actuator:
    """A materially different design: twice the spring, 24 V, a 16-bit encoder, a 14-bit pot, a 1 kHz loop."""
    d = paper_dict()
    d["name"] = "second"
    d["spring"]["stiffness_n_per_mm"] = 8.4
    d["motor"].update(supply_v=24.0, counts_per_rev=65536, gear_ratio=20.0)
    d["pot"]["adc_bits"] = 14
    d["control"]["loop_hz"] = 1000.0
    d["control"]["kd_v_s_per_mm"] = 0.4  # the paper's 0.85 V s/mm does not fit the C's Q12 kd at 1 kHz
    return actuator_from_dict(d, "second")


def toml_of(d: dict) -> str:
    """A description dict as TOML text (numbers, strings and arrays only)."""
    lines = [f"{k} = {v!r}".replace("'", '"') for k, v in d.items() if not isinstance(v, dict)]
    for table, fields in d.items():
        if isinstance(fields, dict):
            lines += [f"[{table}]", *(f"{k} = {v!r}" for k, v in fields.items())]
    return "\n".join(lines) + "\n"


def test_model_and_disagreeing_actuator_refused(tmp_path, capsys):
    """export and verify of a model file recorded for one actuator, given another with --actuator: exit 2,
    one line naming both, nothing written; the agreeing description is accepted."""
    model = tmp_path / "ctl.pt"
    d = load_model(GENERATED / "models" / "sf_control.pt")
    save_model({**d, "actuator": default_actuator().record()}, model)
    other = tmp_path / "other.toml"
    other.write_text(toml_of(second_actuator().to_dict()))
    out = tmp_path / "out"
    rc = main(["export", str(model), "--out", str(out), "--actuator", str(other)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "'second'" in err and "ctl.pt" in err, err
    assert not out.exists()
    same = tmp_path / "same.toml"
    same.write_text(toml_of(default_actuator().to_dict()))
    assert main(["export", str(model), "--out", str(out), "--actuator", str(same)]) == 0
    capsys.readouterr()
    rc = main(["verify", str(out), "--model", str(model), "--vectors", "50", "--actuator", str(other)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "'second'" in err.splitlines()[-1], err


TWO_MAIN = r"""
#include <stdio.h>
#include "one.h"
#include "two.h"
/* stdin: (enc, pot) rows; stdout: one_step and two_step of each row (force 0 N for both). */
int main(void)
{
    one_state_t s1;
    two_state_t s2;
    long e, p;
    one_reset(&s1);
    two_reset(&s2);
    while (scanf("%ld %ld", &e, &p) == 2) {
        int a = one_step(&s1, (int32_t)e, (int32_t)p, 0);
        int b = two_step(&s2, (int32_t)e, (int32_t)p, 0);
        printf("%d %d\n", a, b);
    }
    return 0;
}
"""


def test_two_actuators_exports_compile_into_one_program(tmp_path):
    """Exports of one model recorded for two actuators, written to one folder, link into one program (one
    sea_act_<id> file each); each NAME_step equals the twin fed with its own actuator's constants."""
    from seagen.export import prepare, write
    from seagen.reference import numpy_ref
    from seagen.runtime.features import step_features

    d = load_model(GENERATED / "models" / "sf_control.pt")
    out = tmp_path / "fw"
    exs = []
    for name, act in (("one", default_actuator()), ("two", second_actuator())):
        path = tmp_path / f"{name}.pt"
        save_model({**d, "actuator": act.record()}, path)
        ex = prepare(str(path), name)
        write(ex, out)
        exs.append(ex)
    assert exs[0].act is not None and exs[1].act is not None
    assert len({exs[0].act.cid, exs[1].act.cid}) == 2
    assert {p.name for p in out.glob("sea_act_*.c")} == {f"{x.act.cid}.c" for x in exs if x.act}
    sources = {p.name: p.read_text() for p in out.iterdir() if p.suffix in (".c", ".h")}
    exe = build_exe({**sources, "main.c": TWO_MAIN}, name="two_actuators")
    rng = np.random.default_rng(2)
    enc = np.cumsum(rng.integers(-30, 31, 300)) + 500
    pot = np.clip(1500 + np.cumsum(rng.integers(-20, 21, 300)), 0, 4095)
    res = subprocess.run(
        [str(exe)],
        input="\n".join(f"{e} {p}" for e, p in zip(enc, pot, strict=True)),
        capture_output=True,
        text=True,
        check=True,
    )
    got = np.array([line.split() for line in res.stdout.splitlines()], dtype=np.int64)
    for k, ex in enumerate(exs):
        assert ex.act is not None
        ext = np.zeros((len(enc), 1), dtype=np.int64)
        want = numpy_ref.infer(
            ex.qmodel, step_features(ex.qmodel, ex.act, enc, pot, np.zeros(len(enc), int), ext)
        )
        assert np.array_equal(got[:, k], np.asarray(want).ravel()), ex.prefix
    assert not np.array_equal(got[:, 0], got[:, 1])  # the two geometries give two programs' worth of numbers


def test_manifest_records_the_actuator(tmp_path):
    """The manifest names the description's digest and its geometry file."""
    import json

    from seagen.export import prepare

    ex = prepare(str(GENERATED / "models" / "sf_calibration.pt"), "m")
    man = json.loads(ex.files["m.seagen.json"])
    assert ex.act is not None
    assert man["resolved"]["actuator"] == {
        "name": default_actuator().name,
        "sha256": default_actuator().digest(),
        "file": f"{ex.act.cid}.c",
    }
    assert Path(man["resolved"]["actuator"]["file"]).name in man["files"]


def test_verify_checks_the_geometry_file(tmp_path, capsys):
    """seagen verify fails (exit 1) when the emitted sea_act file was edited, naming the file."""
    model = GENERATED / "models" / "sf_calibration.pt"
    out = tmp_path / "fw"
    assert main(["export", str(model), "--out", str(out), "--prefix", "m"]) == 0
    (act_c,) = out.glob("sea_act_*.c")
    act_c.write_text(act_c.read_text().replace("    73584,", "    73585,"))
    capsys.readouterr()
    assert main(["verify", str(out), "--model", str(model), "--vectors", "50"]) == 1
    assert f"{act_c.name}: edited since export" in capsys.readouterr().out
