"""Shared fixtures of the fit tests: the session's simulated data set and the four default models.

The data set and its derived frames come from conftest.py (generated once per session); these fixtures
only give them the names the fit tests import."""

from __future__ import annotations

from pathlib import Path

import pytest

from seagen.fit.train import train_defaults


@pytest.fixture(scope="session")
def fit_data(data_dir: Path) -> Path:
    """The default simulated data set (paper protocol, seed 0) written as CSVs (conftest.data_dir)."""
    return data_dir


@pytest.fixture(scope="session")
def fit_frames(derived_frames: dict) -> dict:
    """Derived train/test/validation frames of the default data set (conftest.derived_frames)."""
    return derived_frames


@pytest.fixture(scope="session")
def default_models(fit_data: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The four default model files (train_defaults)."""
    return train_defaults(fit_data, tmp_path_factory.mktemp("fitmodels"))
