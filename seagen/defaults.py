"""The default models and their exports, shipped as package data (generated/ in the repository)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from seagen.errors import UserError

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


SCHEME = "default:"


def shipped() -> dict[str, Path]:
    """Every shipped default model: NAME -> its file (what `default:NAME` names)."""
    return {name: default_model(name) for name in DEFAULT_PREFIX}


def resolve_model(arg: str) -> str:
    """A model argument as a path: `default:NAME` is the shipped model NAME; any other text is a path."""
    if not arg.startswith(SCHEME):
        return arg
    name = arg[len(SCHEME) :]
    if name not in DEFAULT_PREFIX:
        known = ", ".join(SCHEME + n for n in DEFAULT_PREFIX)
        raise UserError(f"{arg}: no shipped model '{name}' (shipped: {known}; `seagen models` lists them)")
    return str(default_model(name))


def model_label(path: str) -> str:
    """How a message names a model argument: `default:NAME (file)` for a shipped model, else the path."""
    for name, file in shipped().items():
        if str(file) == str(path):
            return f"{SCHEME}{name} ({file})"
    return str(path)


def model_arg(arg: str) -> str:
    """argparse type of every model argument: a path, or `default:NAME` resolved to the shipped file."""
    import argparse

    try:
        return resolve_model(arg)
    except UserError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
