"""Unit invariants of the SF fit, MLP training determinism and the Optuna search."""

from __future__ import annotations

import io
from dataclasses import replace

import numpy as np
import pytest
import torch
from conftest_fit import fit_data, fit_frames  # noqa: F401  (session fixtures)

from seagen.fit.mlp import MlpConfig, build_module, fit_mlp, predict_mlp
from seagen.fit.search import STRUCTURES, search
from seagen.fit.sf import POWERS, design, eval_sf, fit_sf

TRUE_COEF = np.array([0.5, -1.0, 4.0, 0.02, -0.03, 0.1, 1e-4, -2e-4, 3e-3, -0.01])
QUICK = MlpConfig(hidden=(8,), epochs=8, patience=3)


def _state_bytes(module: torch.nn.Module) -> bytes:
    """Serialized parameters, to compare two trainings bit for bit."""
    buf = io.BytesIO()
    torch.save(module.state_dict(), buf)
    return buf.getvalue()


def test_powers_are_the_ten_third_order_terms() -> None:
    """POWERS lists every (i, j) with i + j <= 3 exactly once, constant first."""
    assert len(POWERS) == 10 and len(set(POWERS)) == 10
    assert POWERS[0] == (0, 0) and all(i + j <= 3 for i, j in POWERS)


@pytest.mark.parametrize("loss", ("mse", "mae"))
def test_sf_recovers_an_exact_polynomial(loss: str) -> None:
    """Noise-free data from a cubic surface over raw-scale inputs is fitted to 1e-6 by both losses."""
    rng = np.random.default_rng(1)
    a, b = rng.uniform(0, 28, 500), rng.uniform(0, 8, 500)
    y = eval_sf({"powers": POWERS, "coef": TRUE_COEF}, a, b)
    sf = fit_sf(a, b, y, loss)
    assert np.allclose(sf["coef"], TRUE_COEF, rtol=1e-5, atol=1e-6)


def test_sf_mae_ignores_outliers_mse_does_not() -> None:
    """With 5 % gross outliers the MAE fit stays near the truth and beats the MSE fit."""
    rng = np.random.default_rng(2)
    a, b = rng.uniform(0, 28, 2000), rng.uniform(0, 8, 2000)
    y = eval_sf({"powers": POWERS, "coef": TRUE_COEF}, a, b)
    noisy = y.copy()
    noisy[rng.choice(2000, 100, replace=False)] += 50.0
    errs = {loss: np.abs(eval_sf(fit_sf(a, b, noisy, loss), a, b) - y).mean() for loss in ("mse", "mae")}
    assert errs["mae"] < 0.01 < errs["mse"]


@pytest.mark.parametrize("seed", (3, 4))
def test_sf_mae_reaches_the_linear_programming_optimum(seed: int) -> None:
    """The IRLS MAE fit's mean absolute residual equals the exact LP optimum (scipy HiGHS) to 1e-6."""
    from scipy.optimize import linprog

    rng = np.random.default_rng(seed)
    a, b = rng.uniform(0, 28, 300), rng.uniform(0, 8, 300)
    y = eval_sf({"powers": POWERS, "coef": TRUE_COEF}, a, b) + rng.laplace(0, 0.5, 300)
    x = design(a, b)
    n, p = x.shape
    lp = linprog(
        np.r_[np.zeros(p), np.ones(2 * n)],
        A_eq=np.hstack([x, np.eye(n), -np.eye(n)]),
        b_eq=y,
        bounds=[(None, None)] * p + [(0, None)] * (2 * n),
        method="highs",
    )
    irls = np.abs(eval_sf(fit_sf(a, b, y, "mae"), a, b) - y).mean()
    assert lp.status == 0 and irls == pytest.approx(lp.fun / n, rel=1e-6)


@pytest.mark.parametrize("task", ("calibration", "control"))
def test_mlp_training_is_deterministic_for_a_seed(task: str, fit_frames: dict) -> None:  # noqa: F811
    """Same seed -> bit-identical weights and predictions; another seed -> different weights."""
    train = fit_frames["train"]
    runs = [fit_mlp(train, task, replace(QUICK, seed=s)) for s in (7, 7, 8)]
    assert _state_bytes(runs[0][0]) == _state_bytes(runs[1][0])
    assert _state_bytes(runs[0][0]) != _state_bytes(runs[2][0])
    p0, p1 = (predict_mlp(m, spec, fit_frames["test"]) for m, spec, _ in runs[:2])
    assert np.array_equal(p0, p1)


@pytest.mark.parametrize(("activation", "layer"), (("relu", torch.nn.ReLU), ("tanh", torch.nn.Tanh)))
def test_module_is_plain_sequential(activation: str, layer: type) -> None:
    """The saved module is nn.Sequential of Linear + activation, one output."""
    m = build_module(9, (16, 32), activation)
    kinds = [type(x) for x in m]
    assert kinds == [torch.nn.Linear, layer, torch.nn.Linear, layer, torch.nn.Linear]
    assert m[-1].out_features == 1


def test_search_shares_a_study_through_storage(fit_frames: dict, tmp_path) -> None:  # noqa: F811
    """Two runs against one sqlite storage and study name add up their trials; the best is a known shape."""
    url = f"sqlite:///{tmp_path / 'sweep.db'}"
    base = replace(QUICK, epochs=3)
    for _ in range(2):
        cfg, study = search(
            fit_frames["train"],
            "control",
            1,
            base,
            storage=url,
            study_name="t",
            progress=False,
            threshold_n=5.0,
        )
    assert len(study.trials) == 2
    assert cfg.hidden in STRUCTURES.values() and cfg.loss in ("mse", "mae") and len(cfg.weights) == 7


@pytest.mark.slow
def test_full_sweep_finds_a_model_under_the_paper_bar(fit_frames: dict) -> None:  # noqa: F811
    """A 16-trial sweep over structure x loss x lr picks a calibration MLP beating 10.18 % on test."""
    from seagen.fit.predict import task_errors

    cfg, study = search(fit_frames["train"], "calibration", 16, MlpConfig(), progress=False, threshold_n=5.0)
    module, spec, _ = fit_mlp(fit_frames["train"], "calibration", cfg)
    test = fit_frames["test"]
    assert task_errors("calibration", predict_mlp(module, spec, test), test, 5.0)["error_avg_pct"] <= 10.18
