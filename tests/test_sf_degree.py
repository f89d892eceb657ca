"""Surface fits of degree above the paper's 3 (hand-written SF dicts and seagen's fitter): Horner in proven
int32 widths, bit for bit between the numpy reference and the C (host; the Cortex-M kernel slow), within
the proven bound of the polynomial on searched inputs, or refused in one line naming the step and the bound
that fails. ~6 s."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from seagen.cli import main
from seagen.export import prepare
from seagen.ir import poly2
from seagen.modelfile import FORMAT
from seagen.reference import numpy_ref
from seagen.reference.float_ref import quantize_features
from seagen.toolchain.model import CModel

RANGE = [[5.0, 28.0], [-0.5, 3.5]]  # angle (deg), compression (mm): the calibration surface's inputs


def _dict(degree: int, seed: int, scale: float = 1.0) -> dict:
    """A full surface of total degree `degree` on RANGE with coefficients of O(1) terms over the box."""
    powers = [[d - j, j] for d in range(degree + 1) for j in range(d + 1)]
    rng = np.random.default_rng(seed)
    mags = [max(abs(lo), abs(hi)) for lo, hi in RANGE]
    coef = [float(rng.uniform(-1, 1) * scale / (mags[0] ** i * mags[1] ** j)) for i, j in powers]
    return {
        "format": FORMAT, "kind": "sf", "task": "calibration", "input_range": RANGE,
        "sf": {"inputs": ["angle_deg", "compression_mm"], "powers": powers, "coef": coef},
    }  # fmt: skip


def _points(n: int = 2000, seed: int = 0) -> np.ndarray:
    lo, hi = np.array(RANGE).T
    span = hi - lo
    lo, hi = lo - 0.125 * span, hi + 0.125 * span  # the widened box the bound is proven on
    rng = np.random.default_rng(seed)
    corners = np.array([[a, b] for a in (lo[0], hi[0]) for b in (lo[1], hi[1])])
    return np.vstack([lo + rng.random((n, 2)) * (hi - lo), corners])


def _export(d: dict, tmp_path):
    p = tmp_path / "sf.pt"
    torch.save(d, p)
    return prepare(str(p), prefix="sf")


@pytest.mark.parametrize("degree", [4, 6])
def test_high_degree_exports_bit_exact_within_bound(degree, tmp_path):
    """Degree 4 and 6: the C equals the numpy reference bit for bit, and |integer - polynomial| stays within
    the proven bound on random points, the corners and around the worst of them."""
    d = _dict(degree, seed=degree)
    ex = _export(d, tmp_path)
    qm = ex.qmodel
    assert qm.n_regs == degree + 1
    x = _points()
    xq = quantize_features(qm, x)
    want = numpy_ref.infer(qm, xq)
    assert np.array_equal(CModel(ex.files, ex.prefix, qm).infer(xq), want)
    sf = d["sf"]
    coef = np.array(sf["coef"])
    powers = tuple(tuple(p) for p in sf["powers"])

    def err(pts: np.ndarray) -> np.ndarray:
        got = numpy_ref.infer(qm, quantize_features(qm, pts)) * 2.0**-qm.out_frac
        return np.abs(got - poly2(powers, coef, pts[:, 0], pts[:, 1]))

    e = err(x)
    worst = x[np.argsort(e)[-5:]]
    rng = np.random.default_rng(1)
    near = (worst[:, None, :] + rng.normal(size=(5, 400, 2)) * [0.05, 0.01]).reshape(-1, 2)
    assert max(e.max(), err(near).max()) <= qm.error_bound, (e.max(), qm.error_bound)


def test_refused_with_the_failing_bound(tmp_path, capsys):
    """A degree-4 term whose coefficient (1e15) is beyond the registers at their coarsest format (the
    products themselves always fit: every step shifts by at least 16): exit 2, one line naming the
    coefficient and the int32 bound it fails; nothing written."""
    d = _dict(4, seed=0)
    d["sf"] = {"inputs": ["angle_deg", "compression_mm"], "powers": [[0, 0], [4, 0]], "coef": [1.0, 1e15]}
    p = tmp_path / "huge.pt"
    torch.save(d, p)
    rc = main(["export", str(p), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert len(err.strip().splitlines()) == 1 and "coefficient 1e+15" in err and "2^30" in err, err
    assert str(p) in err and not (tmp_path / "o").exists()


def test_above_the_cap_is_refused_naming_it(tmp_path, capsys):
    """A power beyond the program-size cap is refused naming the field and the cap."""
    d = _dict(2, seed=0)
    d["sf"]["powers"][-1] = [13, 0]
    p = tmp_path / "deg13.pt"
    torch.save(d, p)
    rc = main(["export", str(p), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and "sf.powers[5]" in err and "i + j <= 12" in err, err


def test_fitter_of_degree_5_exports_within_bound(tmp_path):
    """seagen's SF fitter at order 5 (21 terms) on a smooth surface: the fit is close and exports within
    its proven bound."""
    from seagen.fit.sf import fit_sf

    rng = np.random.default_rng(0)
    lo, hi = np.array(RANGE).T
    x = lo + rng.random((3000, 2)) * (hi - lo)
    y = 4.2 * x[:, 1] * np.cos(np.radians(x[:, 0])) + 0.3 * np.sin(x[:, 0] / 5.0)
    body = fit_sf(x[:, 0], x[:, 1], y, "mse", order=5)
    assert len(body["powers"]) == 21
    d = {"format": FORMAT, "kind": "sf", "task": "calibration", "input_range": RANGE}
    d["sf"] = {"inputs": ["angle_deg", "compression_mm"], **body}
    ex = _export(d, tmp_path)
    xs = _points(500)
    got = numpy_ref.infer(ex.qmodel, quantize_features(ex.qmodel, xs)) * 2.0**-ex.qmodel.out_frac
    powers = tuple(tuple(p) for p in body["powers"])
    want = poly2(powers, np.array(body["coef"]), xs[:, 0], xs[:, 1])
    assert np.max(np.abs(got - want)) <= ex.qmodel.error_bound
    fit_err = np.abs(poly2(powers, np.array(body["coef"]), x[:, 0], x[:, 1]) - y)
    assert fit_err.max() < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("target", ["cortex-m4", "cortex-m0plus"])
def test_high_degree_cortex_m_kernel_bit_exact(target, tmp_path):
    """The straight-line Horner kernel of a degree-6 surface on the emulated core equals the reference."""
    from seagen.toolchain.cortexm import CortexM, toolchain_missing

    if (why := toolchain_missing()) is not None:
        pytest.skip(why)
    p = tmp_path / "sf.pt"
    torch.save(_dict(6, seed=6), p)
    ex = prepare(str(p), prefix="sf", target=target)
    xq = quantize_features(ex.qmodel, _points(300))
    assert np.array_equal(
        CortexM(ex.files, ex.prefix, ex.qmodel, target).infer(xq), numpy_ref.infer(ex.qmodel, xq)
    )
