"""ONNX's backend node tests for the ops seagen claims, symbolic and fixed batch: each is exported within its
proven bound of ONNX's own expected outputs, or refused with one line (never a traceback, never a failed
check). One case per operator and batch form runs in `make test` (~7 s); all of them with `-m slow`."""

from __future__ import annotations

import numpy as np
import pytest

from seagen.errors import UserError
from seagen.export import prepare
from seagen.reference import numpy_ref
from seagen.reference.float_ref import quantize_features
from tests import onnx_node_cases as N

# one case per claimed operator that has a (rows, features) form in ONNX's tests, each exported in both forms
FAST = (
    "test_gemm_default_vector_bias", "test_matmul_2d", "test_add_bcast", "test_sub_bcast", "test_mul_bcast",
    "test_div_bcast", "test_relu", "test_leakyrelu", "test_clip_min_greater_than_max", "test_tanh",
    "test_sigmoid", "test_batchnorm_example", "test_dropout_default", "test_identity",
    "test_cast_FLOAT_to_DOUBLE", "test_flatten_axis1", "test_reshape_reduced_dims",
)  # fmt: skip
# the one 2-D Reshape case reshapes to a constant (2, 12): with a symbolic batch it runs only at 2 rows
REFUSED = {"test_reshape_reduced_dims[symbolic]": "(Reshape): reshape of [N, 12] to [2, 12]: a fixed shape"}
ALL = {c.name: c for c in N.all_cases()}
FAST_NAMES = [f"{n}[{b}]" for n in FAST for b in ("symbolic", "fixed") if f"{n}[{b}]" in ALL]


def _outcome(case: N.NodeCase, tmp_path) -> str:
    """'exported' (within bound + margin of ONNX's expected outputs on the test's rows) or 'refused: ...'."""
    import onnx

    path = tmp_path / "case.onnx"
    onnx.save(case.model, str(path))
    try:
        ex = prepare(str(path), prefix="m", features=case.spec)
    except UserError as e:
        assert "\n" not in str(e) and str(path) in str(e), str(e)
        return f"refused: {e}"
    qm = ex.qmodel
    got = numpy_ref.infer(qm, quantize_features(qm, case.x)) * 2.0**-qm.out_frac
    err = np.max(np.abs(got - case.want))
    assert err <= qm.error_bound + ex.loaded.margin, (case.name, err, qm.error_bound, ex.loaded.margin)
    return "exported"


def test_every_claimed_op_has_a_fast_case():
    """Every claimed op with a case in ONNX's tests is in the fast set, in both batch forms."""
    ops = {c.op for c in ALL.values()}
    fast_ops = {ALL[n].op for n in FAST_NAMES}
    assert ops == fast_ops, sorted(ops - fast_ops)
    assert len(FAST_NAMES) == 2 * len(FAST)


@pytest.mark.parametrize("name", FAST_NAMES)
def test_node_case_exports(name, tmp_path):
    """The representative case of each op and batch form exports within its bound of ONNX's outputs (or is
    refused for the reason REFUSED states)."""
    got = _outcome(ALL[name], tmp_path)
    if name in REFUSED:
        assert got.startswith("refused") and REFUSED[name] in got, got
    else:
        assert got == "exported", got


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(ALL))
def test_node_case(name, tmp_path):
    """Every case: exported within its bound of ONNX's outputs, or refused with one line naming the file."""
    _outcome(ALL[name], tmp_path)
