"""Shared fixtures of the fit tests: the session's simulated data set and the four default models.

The data set and its derived frames come from conftest.py (generated once per session); these fixtures
only give them the names the fit tests import."""

from __future__ import annotations

from pathlib import Path

import pytest

from seagen.fit.train import DEFAULTS, train_defaults


@pytest.fixture(scope="session")
def fit_data(data_dir: Path) -> Path:
    """The default simulated data set (paper protocol, seed 0) written as CSVs (conftest.data_dir)."""
    return data_dir


@pytest.fixture(scope="session")
def fit_frames(derived_frames: dict) -> dict:
    """Derived train/test/validation frames of the default data set (conftest.derived_frames)."""
    return derived_frames


@pytest.fixture(scope="session")
def default_models(
    fit_data: Path, tmp_path_factory: pytest.TempPathFactory, worker_id: str
) -> dict[str, Path]:
    """The four default model files (train_defaults), trained once per run for every xdist worker."""
    from conftest import shared_dir

    d = shared_dir(tmp_path_factory, worker_id, "fitmodels", lambda d: train_defaults(fit_data, d))
    return {name: d / f"{name}.pt" for name in DEFAULTS}
