"""The default models and their exports, shipped as package data (generated/ in the repository)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

DEFAULT_PREFIX = {
    "sf_calibration": "cal_sf",
    "mlp_calibration": "cal_mlp",
    "sf_control": "ctl_sf",
    "mlp_control": "ctl_mlp",
}


def generated_dir() -> Path:
    """The folder of the default exports: generated/ in a checkout, seagen/generated/ in a wheel."""
    return Path(str(resources.files("seagen.generated")))


def default_model(name: str) -> Path:
    """The shipped model file of a default model (e.g. 'mlp_calibration')."""
    return generated_dir() / "models" / f"{name}.pt"


GENERATED = generated_dir()
