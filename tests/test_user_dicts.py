"""Property-based: generated SF model dicts, MLP model dicts and feature specs (hostile types, NaN, Inf, zero
and negative stds, fractional, negative and repeated powers, names differing only in case) either export
within the proven bound — the integer result checked against the polynomial or the torch forward evaluated
here from the dict as written, an oracle seagen did not write — or are refused with exit 2 and one line
naming the file; never a traceback, never a numpy warning line, never exit 0 outside the bound. Each fault
is a parametrisation, so every one is exercised. Derandomized, fixed example counts: ~8 s on 2 busy
cores."""

from __future__ import annotations

import copy
import json
import math
import tempfile
import warnings
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import seagen.export
from seagen.cli import main
from seagen.errors import UserError
from seagen.frontends.load import read_features_file
from seagen.modelfile import FORMAT, FeatureSpec
from seagen.reference import numpy_ref
from seagen.reference.float_ref import quantize_features

VALID_EXAMPLES = 6  # valid cases drawn per example of the fault-free parametrisation
SETTINGS = {
    "derandomize": True,
    "deadline": None,
    "database": None,
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large],
}
ODD = [math.nan, math.inf, -math.inf, "1.5", True, None, [1.0], 1e300]  # not a finite number
NAMES = [["a", "b"], ["pot", "enc"], ["angle_deg", "compression_mm"], ["x_1", "Y"]]
BAD_NAMES: list[Any] = [
    ["a", "A"],
    ["x", "x"],
    "ab",
    ["a b", "c"],
    ["a"],
    ["1x", "y"],
    [3, "y"],
    ["a\n", "b"],
]
# safe in a C comment (non-ASCII units written there as ASCII: N*m, degC, um, Ohm)
PLAIN = ["N", "mm", "N*m", "m/s^2", "", "a / *b", '"q" #x', "deg?", "(1/s)"]
PLAIN += ["N\u00b7m", "\u00b0C", "\u00b5m", "\u2126"]
# the last two: '/·' is written '/*' in the C; a right-to-left override
HOSTILE = ["*/", "/*", "x\\", "??/", "y\n", "\t", "\r", "\u2028", "z" * 80, "N/\u00b7", "\u202eN"]


def finite(lo: float = -1e3, hi: float = 1e3) -> st.SearchStrategy[float]:
    """Finite floats in [lo, hi]."""
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


@st.composite
def box(draw: st.DrawFn, n: int) -> list[list[float]]:
    """n valid [lo, hi] pairs of moderate size."""
    out = []
    for _ in range(n):
        lo, width = draw(finite(-50.0, 50.0)), draw(st.sampled_from([0.5, 3.0, 40.0, 400.0]))
        out.append([lo, lo + width])
    return out


def bad_pair(draw: st.DrawFn) -> Any:
    """A range a user may get wrong: empty, reversed, non-finite, misshapen."""
    return draw(
        st.sampled_from([[1.0, 1.0], [2.0, 1.0], [0.0, math.nan], [0.0, math.inf], [1.0], "0..1", None])
    )


@st.composite
def faults(draw: st.DrawFn, fault: str | None, kinds: list[str]) -> list[str]:
    """The given fault (None: a valid case), sometimes with a second one drawn from `kinds`."""
    if fault is None:
        return []
    return [fault, *([draw(st.sampled_from(kinds))] if draw(st.integers(0, 3)) == 0 else [])]


def break_texts(draw: st.DrawFn, d: dict[str, Any], fault: str) -> None:
    """The text faults: hostile output name, output unit or input unit."""
    if fault == "output_name":
        d["output_name"] = draw(st.sampled_from([*HOSTILE, 7]))
    elif fault == "output_units":
        d["output_units"] = draw(st.sampled_from([*HOSTILE, None]))
    elif fault == "input_units" and isinstance(d.get("input_units"), list) and d["input_units"]:
        d["input_units"][0] = draw(st.sampled_from(HOSTILE))
    elif fault == "input_range":
        d["input_range"][draw(st.integers(0, len(d["input_range"]) - 1))] = bad_pair(draw)


def plain_texts(draw: st.DrawFn, n: int) -> dict[str, Any]:
    """output_name, output_units and input_units of text that is safe in a C comment."""
    t = st.sampled_from(PLAIN)
    return {
        "output_name": draw(st.sampled_from(["force_n", "y", "a / *b", "torque (N*m)"])),
        "output_units": draw(t),
        "input_units": [draw(t) for _ in range(n)],
    }


def run_export(args: list[str]) -> tuple[int, str, Any]:
    """seagen export in this process: exit code, stderr, and the Export it wrote (None unless exit 0)."""
    import contextlib
    import io

    seen: dict[str, Any] = {}
    real = seagen.export.write

    def spy(ex: Any, out_dir: Any) -> Any:
        seen["ex"] = ex
        return real(ex, out_dir)

    err = io.StringIO()
    with (
        warnings.catch_warnings(),  # a numpy RuntimeWarning would be a second line on the console
        mock.patch.object(seagen.export, "write", spy),
        contextlib.redirect_stderr(err),
        contextlib.redirect_stdout(io.StringIO()),
    ):
        warnings.simplefilter("error", RuntimeWarning)
        rc = main(["export", *args])
    return rc, err.getvalue(), seen.get("ex")


def assert_refused_or_within(
    rc: int, err: str, ex: Any, names: list[str], out: Path, oracle: Any, box: list[list[float]]
) -> str:
    """The property: exit 2 with one line naming one of `names` and nothing written, or exit 0 with every
    integer output on the box the user wrote within the proven bound of the oracle (bound + the oracle's
    own float64 rounding)."""
    assert rc in (0, 2), f"exit {rc}: {err}"
    if rc == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in err, err
        assert any(n in err for n in names), err
        assert not out.exists() or not any(out.iterdir()), err
        event(f"refused: {err.split(': ', 3)[-1][:50]}")
        return "refused"
    qm = ex.qmodel
    lo, hi = np.array(box, dtype=float).T
    rng = np.random.default_rng(0)
    k = len(lo)
    unit = np.vstack([rng.random((300, k)), np.indices((2,) * k).reshape(k, -1).T])
    x = lo + unit * (hi - lo)
    got = numpy_ref.infer(qm, quantize_features(qm, x)).astype(float) * 2.0**-qm.out_frac
    want, scale = oracle(x)
    err_max = float(np.max(np.abs(got - want)))
    assert err_max <= qm.error_bound + 1e-9 * (1.0 + scale), (err_max, qm.error_bound)
    event("exported")
    return "exported"


POWERS = [[i, j] for d in range(4) for i in range(d, -1, -1) for j in [d - i]]
SF_FAULTS = [
    "fractional", "negative", "degree", "repeat", "bool", "short", "nan", "inf", "text", "empty", "names",
    "task", "not_a_dict", "output_name", "output_units", "input_units", "input_range", "huge_coef",
    "huge_range",
]  # fmt: skip


@st.composite
def sf_dicts(draw: st.DrawFn, fault: str | None) -> dict[str, Any]:
    """A seagen SF model dict as a user might write one by hand: valid, or with one or two faults."""
    powers = draw(st.lists(st.sampled_from(POWERS), min_size=1, max_size=10, unique_by=tuple))
    coef: list[Any] = [draw(st.sampled_from([-1.0, 1.0])) * draw(finite(0.05, 5.0)) for _ in powers]
    names = draw(st.sampled_from(NAMES))
    d: dict[str, Any] = {
        "format": FORMAT,
        "kind": "sf",
        "task": draw(st.sampled_from(["calibration", "control"])),
    }
    d |= {"input_range": draw(box(2)), **plain_texts(draw, 2)}
    k = draw(st.integers(0, len(powers) - 1))
    fs = draw(faults(fault, SF_FAULTS))
    for f in sorted(fs, key=lambda f: f == "empty"):  # emptied last: the others index a power
        if f in ("fractional", "negative", "degree", "bool"):
            bad = {"fractional": 0.5, "negative": -1, "degree": draw(st.integers(13, 15)), "bool": True}[f]
            powers[k] = [bad, powers[k][1]] if draw(st.booleans()) else [powers[k][0], bad]
        elif f == "repeat":
            powers.append(list(powers[k]))
            coef.append(draw(finite(-5.0, 5.0)))
        elif f == "short":
            coef = coef[:-1]
        elif f in ("nan", "inf", "text"):
            coef[k] = {"nan": math.nan, "inf": -math.inf, "text": "1.5"}[f]
        elif f == "empty":
            powers, coef = [], []
        elif f == "names":
            names = draw(st.sampled_from(BAD_NAMES))
        elif f == "task":
            d["task"] = draw(st.sampled_from(["other", 1, None]))
        elif f == "huge_coef":
            coef[k] = draw(st.sampled_from([1e300, -1e30, 1e-300]))
        elif f == "huge_range":
            d["input_range"][draw(st.integers(0, 1))] = draw(
                st.sampled_from([[-1e300, 1e300], [0.0, 1e-300]])
            )
        else:
            break_texts(draw, d, f)
    sf = {"inputs": names, "powers": powers, "coef": coef}
    d["sf"] = [sf] if "not_a_dict" in fs else sf
    return d


def sf_oracle(d: dict[str, Any]) -> Any:
    """The polynomial of the dict as written, evaluated here in float64: sum c * a^i * b^j (read only when
    the dict was exported)."""

    def f(x: np.ndarray) -> tuple[np.ndarray, float]:
        sf = d["sf"]
        terms = [(float(c), float(i), float(j)) for c, (i, j) in zip(sf["coef"], sf["powers"], strict=True)]
        a, b = x[:, 0], x[:, 1]
        parts = [c * a**i * b**j for c, i, j in terms]
        return np.sum(parts, axis=0), float(np.max(np.sum(np.abs(parts), axis=0)))

    return f


@pytest.mark.parametrize("fault", [None, *SF_FAULTS])
@settings(max_examples=2, **SETTINGS)  # type: ignore[call-overload]
@given(data=st.data())
def test_sf_model_dicts_export_within_bound_or_refused(fault, data):
    """Every SF model dict, valid (VALID_EXAMPLES) or with each fault (2 each): exported within the bound
    of its polynomial, or exit 2 in one line."""
    for _ in range(VALID_EXAMPLES if fault is None else 1):
        check_sf(data.draw(sf_dicts(fault)))


def check_sf(d: dict[str, Any]) -> None:
    """One SF model dict through seagen export."""
    with tempfile.TemporaryDirectory() as tmp:
        p, out = Path(tmp) / "sf.pt", Path(tmp) / "out"
        torch.save(d, p)
        rc, err, ex = run_export([str(p), "--out", str(out)])
        assert_refused_or_within(rc, err, ex, ["sf.pt"], out, sf_oracle(d), d["input_range"])


ACTS = {
    "relu": torch.nn.ReLU,
    "tanh": torch.nn.Tanh,
    "sigmoid": torch.nn.Sigmoid,
    "hardtanh": torch.nn.Hardtanh,
}


MLP_FAULTS = [
    "names", "case", "mean_len", "mean", "std_zero", "std_neg", "std", "weight", "output_mean", "output_std",
    "output_std_inf", "output_name", "output_units", "input_units", "input_range", "huge",
]  # fmt: skip


@st.composite
def mlp_cases(draw: st.DrawFn, fault: str | None) -> tuple[torch.nn.Sequential, dict[str, Any], bool]:
    """A small nn.Sequential and its feature spec (with range and unit keys), valid or with one or two
    faults; True: a seagen model dict, False: the network saved whole with a --features JSON file."""
    n = draw(st.integers(1, 3))
    torch.manual_seed(draw(st.integers(0, 2**16)))
    act = ACTS[draw(st.sampled_from(sorted(ACTS)))]()
    m = torch.nn.Sequential(torch.nn.Linear(n, 4), act, torch.nn.Linear(4, 1)).eval()
    names: Any = draw(st.sampled_from([[f"x{i}" for i in range(n)], ["pot", "enc", "d_enc"][:n]]))
    spec: dict[str, Any] = {"inputs": names, "mean": [draw(finite(-20.0, 20.0)) for _ in range(n)]}
    spec["std"] = [draw(finite(0.05, 50.0)) for _ in range(n)]
    if draw(st.booleans()):
        spec["weight"] = [draw(finite(0.1, 3.0)) for _ in range(n)]
    spec["output_mean"], spec["output_std"] = draw(finite(-20.0, 20.0)), draw(finite(0.05, 20.0))
    spec |= {"input_range": draw(box(n)), **plain_texts(draw, n)}
    if draw(st.booleans()):
        del spec["input_units"]
    k = draw(st.integers(0, n - 1))
    for f in draw(faults(fault, MLP_FAULTS)):
        if f == "names":
            spec["inputs"] = draw(st.sampled_from(BAD_NAMES))
        elif f == "case" and n >= 2:
            spec["inputs"] = ["a", "A", "b"][:n]
        elif f == "mean_len":
            spec["mean"] = spec["mean"][:-1] if draw(st.booleans()) else [*spec["mean"], 0.0]
        elif f == "mean":
            spec["mean"][k] = draw(st.sampled_from(ODD))
        elif f in ("std_zero", "std_neg", "std"):
            spec["std"][k] = {"std_zero": 0.0, "std_neg": -1.0, "std": draw(st.sampled_from(ODD))}[f]
        elif f == "weight":
            spec["weight"] = [draw(st.sampled_from(ODD))] * n
        elif f in ("output_mean", "output_std"):
            spec[f] = draw(st.sampled_from(ODD))
        elif f == "huge":
            key = draw(st.sampled_from(["mean", "std", "output_mean", "output_std", "input_range"]))
            big = {"mean": 1e300, "std": 1e-200, "output_mean": 1e300, "output_std": 1e300}.get(
                key, [0.0, 1e300]
            )
            if key in ("mean", "std", "input_range"):
                spec[key][k] = big
            else:
                spec[key] = big
        elif f == "output_std_inf":
            spec["output_std"] = draw(st.sampled_from([math.inf, 0.0, -2.0]))
        else:
            break_texts(draw, spec, f)
    return m, spec, draw(st.booleans())


def torch_oracle(m: torch.nn.Sequential, spec: dict[str, Any]) -> Any:
    """The network between the spec's normalisation and de-normalisation, as written, in float64 torch."""

    def f(x: np.ndarray) -> tuple[np.ndarray, float]:
        md = copy.deepcopy(m).double()
        mean, std = np.array(spec["mean"], float), np.array(spec["std"], float)
        w = np.array(spec.get("weight") or [1.0] * len(mean), float)
        with torch.no_grad():
            y = md(torch.as_tensor((x - mean) / std * w)).numpy()[:, 0]
        out = y * spec["output_std"] + spec["output_mean"]
        return out, float(np.max(np.abs(out)) + abs(spec["output_mean"]))

    return f


@pytest.mark.parametrize("fault", [None, *MLP_FAULTS])
@settings(max_examples=2, **SETTINGS)  # type: ignore[call-overload]
@given(data=st.data())
def test_mlp_model_dicts_and_specs_export_within_bound_or_refused(fault, data):
    """Every MLP model dict or bare network + --features file, valid (VALID_EXAMPLES) or with each fault
    (2 each): within the bound of its torch forward, or exit 2 in one line naming the model or spec file."""
    for _ in range(VALID_EXAMPLES if fault is None else 1):
        check_mlp(*data.draw(mlp_cases(fault)))


def check_mlp(m: torch.nn.Sequential, spec: dict[str, Any], as_dict: bool) -> None:
    """One network and spec through seagen export."""
    with tempfile.TemporaryDirectory() as tmp:
        p, out, sp = Path(tmp) / "net.pt", Path(tmp) / "out", Path(tmp) / "spec.json"
        keys = ("input_range", "input_units", "output_name", "output_units")
        if as_dict:
            feats = {k: v for k, v in spec.items() if k not in keys}
            d = {"format": FORMAT, "kind": "mlp", "module": m, "features": feats, "task": "calibration"}
            torch.save(d | {k: spec[k] for k in keys if k in spec}, p)
            args = [str(p)]
        else:
            torch.save(m, p)
            sp.write_text(json.dumps(spec))
            args = [str(p), "--features", str(sp)]
        rc, err, ex = run_export([*args, "--out", str(out)])
        assert_refused_or_within(
            rc, err, ex, ["net.pt", "spec.json"], out, torch_oracle(m, spec), spec["input_range"]
        )


SPEC_VALUES: dict[str, list[Any]] = {
    "inputs": [["a", "b"], "ab", ["a", "A"], ["a", 1], [], None, {"a": 1}, ["a", "b", "c"]],
    "mean": [[0.0, 1.0], [math.nan, 0.0], "01", [0.0], [True, 0.0], None, [1e308, -1e308]],
    "std": [[1.0, 2.0], [0.0, 1.0], [-1.0, 1.0], [math.inf, 1.0], ["1", 1.0], 1.0],
    "weight": [[], [1.0, 2.0], [1.0], [math.nan, 1.0], "w"],
    "output_mean": [0.0, math.nan, "0", None, [0.0]],
    "output_std": [1.0, math.inf, 0.0, -1.0, "1"],
    "raw": [["enc", "pot"], "enc", [1, 2]],
    "differences": ["backward", 3, None],
    "sample_rate_hz": [100.0, 0.0, math.nan, "fast"],
    "extra": [{}, [], "x"],
    "task": ["calibration", "control", "other", 1],
    "output_name": ["force_n", "a*/b", "y\n", 7],
    "output_range": [[0.0, 1.0], [1.0, 0.0], [math.nan, 1.0], "0..1"],
    "input_range": [[[0.0, 1.0], [2.0, 3.0]], [[1.0, 1.0], [2.0, 3.0]], [[0.0, math.inf], [0.0, 1.0]], "x"],
    "input_units": [["N", "mm"], ["N"], ["*/", "mm"], "Nmm"],
}


@st.composite
def spec_files(draw: st.DrawFn) -> tuple[str, bytes]:
    """A --features file: JSON of generated fields, a JSON list, binary bytes, bad UTF-8 or a TOML table."""
    d = {
        k: draw(st.sampled_from(v))
        for k, v in SPEC_VALUES.items()
        if draw(st.integers(0, 3)) or k == "inputs"
    }
    d = {k: v for k, v in d.items() if v is not None or draw(st.booleans())}
    form = draw(st.sampled_from(["json"] * 6 + ["list", "binary", "latin1", "toml", "bom"]))
    if form == "list":
        return ".json", json.dumps([d]).encode()
    if form == "binary":
        return ".json", bytes(draw(st.lists(st.integers(0, 255), min_size=1, max_size=64)))
    if form == "latin1":
        return ".json", b'{"inputs": ["\xb0C"]}'
    if form == "toml":
        return ".toml", b'inputs = ["a", "b"]\nstd = [1.0, 0.0]\n'
    if form == "bom":  # as Notepad saves it
        return ".json", b"\xef\xbb\xbf" + json.dumps(d).encode()
    return ".json", json.dumps(d).encode()


@settings(max_examples=100, **SETTINGS)  # type: ignore[call-overload]
@given(spec_files())
def test_feature_spec_files_read_or_refused_in_one_line(case):
    """Reading a --features file: a spec whose every number is finite, every std > 0, input names distinct
    C identifiers (not only in case), or one UserError line naming the file and (for a field) the field."""
    suffix, content = case
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / f"spec{suffix}"
        p.write_bytes(content)
        try:
            out = read_features_file(str(p))
        except UserError as e:
            msg = str(e)
            assert "\n" not in msg and msg.startswith(str(p)), msg
            return
    spec = FeatureSpec.from_dict(out["features"])
    nums = [*spec.mean, *spec.std, *spec.weight, spec.output_mean, spec.output_std, spec.sample_rate_hz]
    assert all(isinstance(v, float) and math.isfinite(v) for v in nums)
    assert min(spec.std) > 0 and spec.output_std > 0
    assert len({n.upper() for n in spec.inputs}) == len(spec.inputs)
    assert all(isinstance(n, str) and n.isidentifier() and n.isascii() for n in spec.inputs)
