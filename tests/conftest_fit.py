"""Shared fixtures of the fit tests: one simulated data set and the four default models per session."""

from __future__ import annotations

from pathlib import Path

import pytest

from seagen.data.protocol import generate
from seagen.data.schema import save_csv
from seagen.fit.train import load_derived, train_defaults
from seagen.plant import PlantConfig


@pytest.fixture(scope="session")
def fit_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default simulated data set (paper protocol, seed 0) written as CSVs."""
    out = tmp_path_factory.mktemp("fitdata")
    for name, df in generate(PlantConfig(), seed=0).items():
        save_csv(df, out / f"{name}.csv")
    return out


@pytest.fixture(scope="session")
def fit_frames(fit_data: Path) -> dict:
    """Derived train/test/validation frames of the default data set."""
    return load_derived(fit_data)


@pytest.fixture(scope="session")
def default_models(fit_data: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The four default model files (train_defaults)."""
    return train_defaults(fit_data, tmp_path_factory.mktemp("fitmodels"))
