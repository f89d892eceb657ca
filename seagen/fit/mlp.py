"""MLP calibration (paper §V) and weighted-input compression predictor (§VI-B/C), trained with torch."""

from __future__ import annotations

import contextlib
import copy
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import torch
from torch import nn

from seagen.data.features import MLP_FEATURES
from seagen.modelfile import FeatureSpec

CONTROL_FEATURES = ("force_n", "pot", "d_pot", "dd_pot", "d_enc", "dd_enc", "d_compression_mm")
MLP_INPUTS = {"calibration": MLP_FEATURES, "control": CONTROL_FEATURES}
MLP_OUTPUT = {"calibration": "force_n", "control": "compression_mm"}
RAW_SIGNALS = {"calibration": ("enc", "pot"), "control": ("force_n", "enc", "pot")}
# Paper §VI-C: the desired force matters most, angle and travel less, speed and acceleration little.
DEFAULT_CONTROL_WEIGHTS = (2.0, 1.0, 0.5, 0.25, 0.5, 0.25, 0.5)
ACTIVATIONS: dict[str, type[nn.Module]] = {"relu": nn.ReLU, "leaky_relu": nn.LeakyReLU, "tanh": nn.Tanh}
UNITS = {
    "pot": "count",
    "enc": "count",
    "compression_mm": "mm",
    "angle_deg": "deg",
    "force_n": "N",
}


def unit_of(name: str) -> str:
    """Unit string of a feature name (differences are per sample at the feature sample rate)."""
    if name.startswith("dd_"):
        return f"{UNITS[name[3:]]}/sample^2"
    if name.startswith("d_"):
        return f"{UNITS[name[2:]]}/sample"
    return UNITS[name]


@dataclass(frozen=True)
class MlpConfig:
    """Hyper-parameters of one MLP training run."""

    hidden: tuple[int, ...] = (16, 32)
    loss: str = "mse"
    lr: float = 3e-3
    activation: str = "relu"
    weights: tuple[float, ...] = ()  # per-input weights; () = all 1
    epochs: int = 300
    batch: int = 256
    patience: int = 30
    holdout: float = 0.15  # share of training trials used for early stopping
    seed: int = 0
    extra: dict[str, float] = field(default_factory=dict)


def make_spec(df: pd.DataFrame, task: str, weights: Sequence[float] = ()) -> FeatureSpec:
    """Feature spec with normalization statistics of `df` (the training rows); `train` sets its sample
    rate to the actuator's control-loop rate."""
    inputs = MLP_INPUTS[task]
    x = df[list(inputs)].to_numpy(dtype=float)
    y = df[MLP_OUTPUT[task]].to_numpy(dtype=float)
    std = x.std(axis=0)
    std[std == 0] = 1.0
    return FeatureSpec(
        inputs=tuple(inputs),
        mean=tuple(float(v) for v in x.mean(axis=0)),
        std=tuple(float(v) for v in std),
        weight=tuple(float(w) for w in weights),
        output_mean=float(y.mean()),
        output_std=float(y.std() or 1.0),
        raw=RAW_SIGNALS[task],
    )


def normalize(spec: FeatureSpec, df: pd.DataFrame) -> np.ndarray:
    """x_model = (x - mean) / std * weight, float64, one row per sample."""
    x = df[list(spec.inputs)].to_numpy(dtype=float)
    return (x - np.asarray(spec.mean)) / np.asarray(spec.std) * np.asarray(spec.weights())


def build_module(n_in: int, hidden: Sequence[int], activation: str = "relu") -> nn.Sequential:
    """Linear + activation layers, one linear output."""
    layers: list[nn.Module] = []
    for h in hidden:
        layers += [nn.Linear(n_in, h), ACTIVATIONS[activation]()]
        n_in = h
    layers.append(nn.Linear(n_in, 1))
    return nn.Sequential(*layers)


def holdout_mask(df: pd.DataFrame, share: float, seed: int) -> np.ndarray:
    """True for rows of whole trials (per contact angle) held out for early stopping."""
    keys = df["angle_set_deg"].astype(str) + "/" + df["trial"].astype(str)
    groups = np.array(sorted(keys.unique()))
    rng = np.random.default_rng(seed)
    n = max(1, int(round(share * len(groups))))
    held = set(rng.choice(groups, size=n, replace=False))
    return keys.isin(held).to_numpy()


@contextlib.contextmanager
def deterministic(seed: int) -> Iterator[None]:
    """Seeded, deterministic, single-threaded torch inside the block; restores the previous settings."""
    threads = torch.get_num_threads()
    was_det = torch.are_deterministic_algorithms_enabled()
    torch.set_num_threads(1)
    torch.use_deterministic_algorithms(True)
    torch.manual_seed(seed)
    try:
        yield
    finally:
        torch.use_deterministic_algorithms(was_det)
        torch.set_num_threads(threads)


def _loss_fn(loss: str) -> nn.Module:
    """Eq. 8 (MSE) or Eq. 7 (MAE) on normalized outputs."""
    if loss == "mse":
        return nn.MSELoss()
    if loss == "mae":
        return nn.L1Loss()
    raise ValueError(f"unknown loss {loss!r}")


def _tensors(spec: FeatureSpec, df: pd.DataFrame, output: str) -> tuple[torch.Tensor, torch.Tensor]:
    """Normalized float32 inputs and outputs."""
    x = torch.tensor(normalize(spec, df), dtype=torch.float32)
    y = (df[output].to_numpy(dtype=float) - spec.output_mean) / spec.output_std
    return x, torch.tensor(y, dtype=torch.float32)[:, None]


def _run_epochs(module: nn.Sequential, data: tuple[torch.Tensor, ...], cfg: MlpConfig) -> tuple[float, int]:
    """Adam on minibatches with early stopping; leaves the best state loaded; returns (best loss, epochs)."""
    x, y, xv, yv = data
    opt = torch.optim.Adam(module.parameters(), lr=cfg.lr)
    crit = _loss_fn(cfg.loss)
    best, best_state, since, epochs = float("inf"), copy.deepcopy(module.state_dict()), 0, 0
    while epochs < cfg.epochs and since < cfg.patience:
        epochs += 1
        module.train()
        for idx in torch.randperm(len(x)).split(cfg.batch):
            opt.zero_grad()
            crit(module(x[idx]), y[idx]).backward()
            opt.step()
        module.eval()
        with torch.no_grad():
            val = float(crit(module(xv), yv))
        if val < best - 1e-6:
            best, best_state, since = val, copy.deepcopy(module.state_dict()), 0
        else:
            since += 1
    module.load_state_dict(best_state)
    return best, epochs


def fit_mlp(train_df: pd.DataFrame, task: str, cfg: MlpConfig) -> tuple[nn.Sequential, FeatureSpec, dict]:
    """Train one MLP on derived training rows; returns (module, spec, info with early-stopping details)."""
    weights = cfg.weights or (DEFAULT_CONTROL_WEIGHTS if task == "control" else ())
    spec = make_spec(train_df, task, weights)
    held = holdout_mask(train_df, cfg.holdout, cfg.seed)
    output = MLP_OUTPUT[task]
    with deterministic(cfg.seed):
        module = build_module(len(spec.inputs), cfg.hidden, cfg.activation)
        x, y = _tensors(spec, train_df[~held], output)
        xv, yv = _tensors(spec, train_df[held], output)
        best, epochs = _run_epochs(module, (x, y, xv, yv), cfg)
    module.eval()
    info = {"holdout_loss": best, "epochs": epochs, "holdout_mask": held}
    return module, spec, info


def predict_mlp(module: nn.Module, spec: FeatureSpec, df: pd.DataFrame) -> np.ndarray:
    """Float reference of an MLP model: normalize, run the module, de-normalize (float64 result)."""
    x = torch.tensor(normalize(spec, df), dtype=torch.float32)
    with torch.no_grad():
        y = module(x).double().numpy().reshape(-1)
    return y * spec.output_std + spec.output_mean
