"""Shared fixtures: one simulated data set per test session, and small models in the model-file format."""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
import torch

from seagen.data.features import MLP_FEATURES
from seagen.fit.mlp import CONTROL_FEATURES
from seagen.modelfile import FeatureSpec, save_model

# the second design shipped as an example
EXAMPLE_ACTUATOR = Path(__file__).resolve().parents[1] / "examples" / "actuators" / "stiff_24v.toml"
ACTS = {
    "relu": torch.nn.ReLU,
    "leaky_relu": lambda: torch.nn.LeakyReLU(0.05),
    "tanh": torch.nn.Tanh,
    "sigmoid": torch.nn.Sigmoid,
    "hardtanh": lambda: torch.nn.Hardtanh(-2.0, 2.0),
}


def run_cli(*args: str) -> tuple[int, str, str]:
    """`seagen ARGS` in this process (no interpreter start-up): exit code, stdout, stderr. An exception
    that `main` lets through fails the test, as a traceback would in a subprocess."""
    from seagen.cli import main

    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as e:  # argparse's usage errors
            code = e.code if isinstance(e.code, int) else 2
    return code, out.getvalue(), err.getvalue()


def shared_dir(tmp_path_factory, worker_id: str, name: str, make) -> Path:
    """A folder made once for the whole test run, shared by the xdist workers: the first to come makes it
    under a file lock (make(folder)), the others wait and reuse it."""
    from filelock import FileLock

    base = tmp_path_factory.getbasetemp()
    root = base if worker_id == "master" else base.parent
    d, done = root / name, root / f"{name}.done"
    with FileLock(str(d) + ".lock"):
        if not done.is_file():
            d.mkdir(exist_ok=True)
            make(d)
            done.touch()
    return d


def _write_default_data(d: Path) -> None:
    """The default simulated data set (seed 0) as CSVs in d."""
    from seagen.data.protocol import generate
    from seagen.data.schema import save_csv
    from seagen.plant import PlantConfig

    for split, df in generate(PlantConfig(), seed=0).items():
        save_csv(df, d / f"{split}.csv")


@pytest.fixture(scope="session")
def data_dir(tmp_path_factory, worker_id):
    """The default simulated data set (seed 0): train.csv, test.csv, validation.csv (made once per run)."""
    return shared_dir(tmp_path_factory, worker_id, "data-seed0", _write_default_data)


@pytest.fixture(scope="session")
def derived_frames(data_dir):
    """Derived train/test/validation frames of the default data set (shared, do not modify)."""
    from seagen.fit.train import load_derived

    return load_derived(data_dir)


@pytest.fixture(scope="session")
def train_df(derived_frames):
    """Derived training rows."""
    return derived_frames["train"]


def quick_mlp(df, inputs, output, hidden=(16, 32), act="relu", steps=200, seed=0) -> dict:
    """A small MLP fitted for a few hundred full-batch Adam steps on every 4th row, as a seagen model dict."""
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    x, y = df[list(inputs)].to_numpy(), df[output].to_numpy()
    xs, ys_ = x[::4], y[::4]
    mean, std, ym, ys = x.mean(0), x.std(0) + 1e-9, y.mean(), y.std()
    sizes = [len(inputs), *hidden]
    mods: list[torch.nn.Module] = []
    for a, b in zip(sizes[:-1], sizes[1:], strict=True):
        mods += [torch.nn.Linear(a, b), ACTS[act]()]
    net = torch.nn.Sequential(*mods, torch.nn.Linear(sizes[-1], 1))
    xt = torch.tensor((xs - mean) / std, dtype=torch.float32)
    yt = torch.tensor((ys_ - ym) / ys, dtype=torch.float32)[:, None]
    opt = torch.optim.Adam(net.parameters(), 3e-3)
    for _ in range(steps):
        opt.zero_grad()
        loss = ((net(xt) - yt) ** 2).mean()
        loss.backward()
        opt.step()
    spec = FeatureSpec(tuple(inputs), tuple(mean), tuple(std), output_mean=float(ym), output_std=float(ys))
    return {
        "kind": "mlp",
        "task": "control" if output == "compression_mm" else "calibration",
        "module": net,
        "features": spec.to_dict(),
        "output_name": output,
        "output_units": "mm" if output != "force_n" else "N",
        "input_range": [[float(x[:, i].min()), float(x[:, i].max())] for i in range(len(inputs))],
        "output_range": [float(y.min()), float(y.max())],
        "loss": "mse",
        "seed": seed,
        "hidden": list(hidden),
    }


def quick_sf(df, inputs, output) -> dict:
    """A least-squares 3rd-order surface fit as a seagen model dict."""
    a, b = df[inputs[0]].to_numpy(), df[inputs[1]].to_numpy()
    powers = [(i, j) for i in range(4) for j in range(4) if i + j <= 3]
    coef, *_ = np.linalg.lstsq(
        np.stack([a**i * b**j for i, j in powers], 1), df[output].to_numpy(), rcond=None
    )
    return {
        "kind": "sf",
        "task": "control" if output == "compression_mm" else "calibration",
        "sf": {"inputs": list(inputs), "powers": [list(p) for p in powers], "coef": coef.tolist()},
        "output_name": output,
        "output_units": "mm" if output != "force_n" else "N",
        "input_range": [[float(a.min()), float(a.max())], [float(b.min()), float(b.max())]],
        "output_range": [float(df[output].min()), float(df[output].max())],
        "loss": "mse",
        "seed": 0,
    }


MODEL_CASES = {
    "mlp_relu": lambda df: quick_mlp(df, MLP_FEATURES, "force_n"),
    "mlp_leaky": lambda df: quick_mlp(df, MLP_FEATURES, "force_n", (8, 16), "leaky_relu"),
    "mlp_hardtanh": lambda df: quick_mlp(df, MLP_FEATURES, "force_n", (8, 16), "hardtanh"),
    "mlp_tanh": lambda df: quick_mlp(df, MLP_FEATURES, "force_n", (8, 16, 32), "tanh"),
    "mlp_sigmoid": lambda df: quick_mlp(df, MLP_FEATURES, "force_n", (8,), "sigmoid"),
    "mlp_control": lambda df: quick_mlp(df, CONTROL_FEATURES, "compression_mm", (8, 16)),
    "sf_calibration": lambda df: quick_sf(df, ("angle_deg", "compression_mm"), "force_n"),
    "sf_control": lambda df: quick_sf(df, ("force_n", "angle_deg"), "compression_mm"),
}


@pytest.fixture(scope="session")
def model_files(tmp_path_factory, train_df):
    """Every case of MODEL_CASES saved as a model.pt."""
    d = tmp_path_factory.mktemp("models")
    out = {}
    for name, make in MODEL_CASES.items():
        save_model(make(train_df), d / f"{name}.pt")
        out[name] = d / f"{name}.pt"
    return out
