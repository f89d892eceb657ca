"""seagen export: the generated C equals the numpy reference, the torch twin and onnxruntime, bit for bit."""

from __future__ import annotations

import re

import numpy as np
import pytest

from seagen.data.features import derive
from seagen.data.schema import load_split
from seagen.export import prepare
from seagen.reference import float_ref, numpy_ref
from seagen.runtime.actq import act_q_of
from seagen.runtime.features import external_inputs, step_features
from seagen.toolchain.equivalence import compare, edge_inputs, first_mismatch, random_inputs
from seagen.toolchain.model import CModel, sanitized_infer
from tests.conftest import MODEL_CASES

CASES = sorted(MODEL_CASES)
WEIGHTS = {"mlp_relu": ("int16", "int8")}


def _exports(model_files):
    for name in CASES:
        for w in WEIGHTS.get(name, ("int16",)):
            yield name, w, prepare(str(model_files[name]), prefix=f"t_{name}_{w}", weights=w, with_onnx=True)


@pytest.fixture(scope="module")
def built(model_files):
    """Every test model exported and built with cffi (strict flags), keyed by (case, weights)."""
    out = {}
    for name, w, ex in _exports(model_files):
        out[(name, w)] = (ex, CModel(ex.files, ex.prefix, ex.qmodel))
    return out


KEYS = [(n, w) for n in CASES for w in WEIGHTS.get(n, ("int16",))]


@pytest.mark.parametrize("key", KEYS, ids=[f"{n}-{w}" for n, w in KEYS])
def test_random_and_edge_inputs_bit_exact(built, key):
    """100,000 random inputs across and beyond the calibrated range, and edge inputs: all four agree."""
    ex, c = built[key]
    onnx_model = None
    for name, x in (
        ("random", random_inputs(ex.qmodel, 100_000, 1)),
        ("edge", edge_inputs(len(ex.qmodel.inputs))),
    ):
        chk = compare(f"{key} {name}", ex.qmodel, c, x, onnx_model)
        assert chk.ok, chk.line()


@pytest.mark.parametrize("key", KEYS, ids=[f"{n}-{w}" for n, w in KEYS])
def test_data_sets_and_step_pipeline_bit_exact(built, key, data_dir):
    """NAME_infer on test/validation features and NAME_step on whole recorded trials equal the references."""
    ex, c = built[key]
    qm = ex.qmodel
    names = [i.signal.name for i in qm.inputs]
    ext = external_inputs(qm)
    for split in ("test", "validation"):
        df = derive(load_split(data_dir, split))
        xq = float_ref.quantize_features(qm, df[names].to_numpy())
        chk = compare(f"{key} {split}", qm, c, xq)
        assert chk.ok, chk.line()
        e = xq[:, [names.index(n) for n in ext]] if ext else None
        want = numpy_ref.infer(qm, step_features(qm, act_q_of(), df.enc, df.pot, df.trial, e))
        got = c.step(df.enc.to_numpy(), df.pot.to_numpy(), df.trial.to_numpy(), e)
        bad = first_mismatch(got, want, df[["trial", "enc", "pot"]].to_numpy())
        assert bad is None, f"{key} {split} NAME_step: {bad}"


@pytest.mark.parametrize("key", KEYS, ids=[f"{n}-{w}" for n, w in KEYS])
def test_step_features_within_quantization_of_float_features(built, key, data_dir):
    """The integer pipeline's features stay within half an LSB (+1.5e-4 mm for compression) of derive()."""
    ex, _ = built[key]
    qm = ex.qmodel
    df = derive(load_split(data_dir, "test"))
    names = [i.signal.name for i in qm.inputs]
    ext = external_inputs(qm)
    e = (
        float_ref.quantize_features(qm, df[names].to_numpy())[:, [names.index(n) for n in ext]]
        if ext
        else None
    )
    feats = step_features(qm, act_q_of(), df.enc, df.pot, df.trial, e)
    for k, qi in enumerate(qm.inputs):
        x = df[qi.signal.name].to_numpy()
        inside = (x * 2.0**qi.frac > qi.lo_q) & (x * 2.0**qi.frac < qi.hi_q)
        # dd sums 4 compression errors of 1.5e-4 mm; the Q24 angle constant is off by 2.7e-8 deg per count
        slack = (
            4 * 1.5e-4 if "compression" in qi.signal.name else 1.2e-4 if qi.signal.name == "angle_deg" else 0
        )
        err = np.abs(feats[inside, k] * 2.0**-qi.frac - x[inside])
        assert err.max() <= 2.0 ** -(qi.frac + 1) + slack + 1e-9, (qi.signal.name, err.max())


@pytest.mark.parametrize("key", KEYS, ids=[f"{n}-{w}" for n, w in KEYS])
def test_sanitized_build_agrees(built, key):
    """A UBSan+ASan build of the generated C runs random and edge inputs without a report, same integers."""
    ex, c = built[key]
    x = np.vstack([random_inputs(ex.qmodel, 20_000, 2), edge_inputs(len(ex.qmodel.inputs))])
    got = sanitized_infer(ex.files, ex.prefix, ex.qmodel, x)
    assert np.array_equal(got, c.infer(x))


@pytest.mark.parametrize("key", KEYS, ids=[f"{n}-{w}" for n, w in KEYS])
def test_error_bound_holds(built, key, data_dir):
    """|fixed - float| on the test rows inside the box never exceeds the proven bound."""
    ex, c = built[key]
    qm = ex.qmodel
    names = [i.signal.name for i in qm.inputs]
    df = derive(load_split(data_dir, "test"))
    x = df[names].to_numpy()
    fixed = c.infer(float_ref.quantize_features(qm, x)) * 2.0**-qm.out_frac
    err = np.abs(fixed - float_ref.predict(ex.float_model, x))
    assert err.max() <= qm.error_bound, (err.max(), qm.error_bound)


def _strip_comments(text: str) -> str:
    return re.sub(r"/\*.*?\*/", "", text, flags=re.S)


@pytest.mark.parametrize("key", KEYS, ids=[f"{n}-{w}" for n, w in KEYS])
def test_generated_code_quality(built, key):
    """No float/double/malloc/libm, const tables, every symbol prefixed, the header comment complete."""
    ex, _ = built[key]
    h, c = ex.files[f"{ex.prefix}.h"], ex.files[f"{ex.prefix}.c"]
    for text in (h, c):
        code = _strip_comments(text)
        assert not re.search(r"\b(float|double|malloc|calloc|free|math\.h)\b", code)
    assert "seagen 0.1.0" in h and "proven |fixed - float|" in h and "model " in h
    for decl in re.findall(r"^static (?!const)[^;(]*\[", c, flags=re.M):
        pytest.fail(f"non-const static table: {decl}")
    globals_ = re.findall(r"^(?:[a-z0-9_]+\s+)+\**([A-Za-z_]\w*)\s*\(", _strip_comments(c), flags=re.M)
    assert globals_ and all(g.startswith(ex.prefix + "_") for g in globals_), globals_


def test_rendering_is_byte_identical(model_files):
    """The same model and options give byte-identical files (C and ONNX)."""
    a = prepare(str(model_files["mlp_tanh"]), prefix="same", with_onnx=True)
    b = prepare(str(model_files["mlp_tanh"]), prefix="same", with_onnx=True)
    assert a.files == b.files and a.onnx_bytes == b.onnx_bytes
