"""Read any supported model (seagen model.pt, nn.Sequential, TorchScript, ONNX) into the float IR."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from seagen.errors import UserError
from seagen.fit.modelfile import FORMAT, FeatureSpec
from seagen.ir import FloatLayer, FloatMLP, FloatModel, FloatSF, Signal

UNITS = {"pot": "count", "enc": "count", "angle_deg": "deg", "compression_mm": "mm", "force_n": "N"}


def unit_of(name: str) -> str:
    """Physical unit of a feature name (differences are per 10 ms sample)."""
    base = name.removeprefix("dd_").removeprefix("d_")
    return UNITS.get(base, "")


def _check_finite(arrays: list[np.ndarray], where: str) -> None:
    for a in arrays:
        if not np.all(np.isfinite(a)):
            raise UserError(f"{where}: weights contain NaN or Inf")


def layers_from_modules(mods: list[Any], where: str) -> list[FloatLayer]:
    """Linear + activation modules (torch or TorchScript) -> FloatLayers; unsupported layers are errors."""
    layers: list[FloatLayer] = []
    for i, m in enumerate(mods):
        kind = getattr(m, "original_name", type(m).__name__)
        if kind == "Linear":
            w = m.weight.detach().double().numpy()
            b = m.bias.detach().double().numpy() if m.bias is not None else np.zeros(w.shape[0])
            _check_finite([w, b], f"{where}: layer {i} (Linear)")
            layers.append(FloatLayer(w, b))
        elif kind in ("ReLU", "LeakyReLU", "Hardtanh", "Tanh", "Sigmoid", "Identity"):
            if not layers:
                raise UserError(f"{where}: layer {i} ({kind}) comes before any Linear layer")
            if kind != "Identity":
                layers[-1] = _with_activation(layers[-1], kind, m, where, i)
        else:
            raise UserError(
                f"{where}: layer {i} is an unsupported {kind} "
                "(supported: Linear, ReLU, LeakyReLU, Hardtanh, Tanh, Sigmoid)"
            )
    if not layers:
        raise UserError(f"{where}: no Linear layer found")
    return layers


def _with_activation(layer: FloatLayer, kind: str, m: Any, where: str, i: int) -> FloatLayer:
    if layer.activation != "linear":
        raise UserError(f"{where}: layer {i} stacks two activations")
    act = {
        "ReLU": "relu",
        "LeakyReLU": "leaky_relu",
        "Hardtanh": "hardtanh",
        "Tanh": "tanh",
        "Sigmoid": "sigmoid",
    }[kind]
    return FloatLayer(
        layer.weight,
        layer.bias,
        act,
        alpha=float(getattr(m, "negative_slope", 0.01)),
        lo=float(getattr(m, "min_val", -1.0)),
        hi=float(getattr(m, "max_val", 1.0)),
    )


def fold_normalization(layers: list[FloatLayer], spec: FeatureSpec) -> list[FloatLayer]:
    """Fold x_model = (x - mean)/std * w into the first layer and y = y_m * std + mean into the last."""
    scale = np.array(spec.weights()) / np.array(spec.std)
    first = layers[0]
    if first.weight.shape[1] != len(spec.inputs):
        raise UserError(
            f"the first layer takes {first.weight.shape[1]} inputs but the feature specification "
            f"names {len(spec.inputs)} ({', '.join(spec.inputs)})"
        )
    w1 = first.weight * scale[None, :]
    b1 = first.bias - first.weight @ (np.array(spec.mean) * scale)
    out = [FloatLayer(w1, b1, first.activation, first.alpha, first.lo, first.hi), *layers[1:]]
    last = out[-1]
    if last.activation == "linear":
        out[-1] = FloatLayer(last.weight * spec.output_std, last.bias * spec.output_std + spec.output_mean)
    elif spec.output_std != 1.0 or spec.output_mean != 0.0:
        out.append(FloatLayer(np.array([[spec.output_std]]), np.array([spec.output_mean])))
    if out[-1].weight.shape[0] != 1:
        raise UserError(f"the model has {out[-1].weight.shape[0]} outputs; seagen exports one-output models")
    return out


def signals(spec: FeatureSpec, ranges: Any, units: Any, where: str) -> tuple[Signal, ...]:
    """Input signals with their calibrated ranges; a missing or bad range is an error."""
    if callable(ranges):
        ranges = ranges(list(spec.inputs))
    if ranges is None:
        raise UserError(f"{where}: no calibrated input range (give --calib DATA_DIR or 'input_range')")
    ranges = [list(map(float, r)) for r in ranges]
    if len(ranges) != len(spec.inputs):
        raise UserError(f"{where}: input_range has {len(ranges)} entries for {len(spec.inputs)} inputs")
    units = list(units) if units else [unit_of(n) for n in spec.inputs]
    out = []
    for n, (lo, hi), u in zip(spec.inputs, ranges, units, strict=True):
        if not (np.isfinite(lo) and np.isfinite(hi) and hi >= lo):
            raise UserError(f"{where}: input '{n}' has an invalid range [{lo}, {hi}]")
        out.append(Signal(n, u, lo, hi))
    return tuple(out)


def from_model_dict(d: dict[str, Any], where: str, ranges: Any = None) -> FloatModel:
    """Float IR from a seagen model dict (or an equivalent dict built from a features file)."""
    spec = FeatureSpec.from_dict(d.get("features") or {}, where) if d.get("features") else None
    rng = ranges if ranges is not None else d.get("input_range")
    out_rng = d.get("output_range") or [0.0, 0.0]
    output = Signal(
        d.get("output_name", "y"), d.get("output_units", ""), float(out_rng[0]), float(out_rng[1])
    )
    task = d.get("task", "calibration")
    if d.get("kind") == "sf":
        sf = d["sf"]
        fake = FeatureSpec(tuple(sf["inputs"]), (0.0, 0.0), (1.0, 1.0))
        coef = np.asarray(sf["coef"], dtype=float)
        _check_finite([coef], where)
        a, b = signals(fake, rng, d.get("input_units"), where)
        return FloatSF(
            (a, b),
            output,
            tuple(tuple(p) for p in sf["powers"]),
            tuple(coef.tolist()),
            task,
        )
    if spec is None:
        raise UserError(f"{where}: no feature specification (give --features SPEC)")
    module: Any = d.get("module")
    mods = list(module.children()) if hasattr(module, "children") else []
    layers = fold_normalization(layers_from_modules(mods, where), spec)
    return FloatMLP(signals(spec, rng, d.get("input_units"), where), output, tuple(layers), task)


def read_features_file(path: str | None) -> dict[str, Any]:
    """A --features SPEC file (JSON or TOML) -> dict with 'features' and optional range/unit keys."""
    if path is None:
        return {}
    p = Path(path)
    if not p.is_file():
        raise UserError(f"{p}: no such feature specification file")
    try:
        raw = tomllib.loads(p.read_text()) if p.suffix == ".toml" else json.loads(p.read_text())
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as e:
        raise UserError(f"{p}: cannot parse: {e}") from None
    keys = ("input_range", "input_units", "output_name", "output_units", "output_range", "task")
    out = {k: raw[k] for k in keys if k in raw}
    out["features"] = {k: v for k, v in raw.items() if k not in keys}
    FeatureSpec.from_dict(out["features"], str(p))
    return out


def load_float_model(path: str, features: str | None = None, ranges: Any = None) -> FloatModel:
    """Any supported model file -> float IR (a features file overrides/fills the model's own metadata).

    `ranges` (a list of [lo, hi] or a function of the input names returning one) overrides the model's own
    calibrated input ranges.
    """
    p = Path(path)
    if not p.is_file():
        raise UserError(f"{p}: no such model file")
    extra = read_features_file(features)
    if p.suffix == ".onnx":
        from seagen.quant.load_onnx import onnx_layers

        d = {"kind": "mlp", **extra, "module": None}
        spec = FeatureSpec.from_dict(extra.get("features") or _need_features(p), str(p))
        layers = fold_normalization(onnx_layers(p), spec)
        return FloatMLP(
            signals(
                spec, ranges if ranges is not None else d.get("input_range"), d.get("input_units"), str(p)
            ),
            Signal(d.get("output_name", "y"), d.get("output_units", ""), 0.0, 0.0),
            tuple(layers),
            d.get("task", "calibration"),
        )
    obj = _torch_load(p)
    if isinstance(obj, dict) and obj.get("format") == FORMAT:
        return from_model_dict({**obj, **extra}, str(p), ranges)
    if isinstance(obj, dict):
        raise UserError(f"{p}: a dict but not a seagen model file (no format '{FORMAT}')")
    if not extra:
        _need_features(p)
    return from_model_dict({"kind": "mlp", **extra, "module": obj}, str(p), ranges)


def _need_features(p: Path) -> dict[str, Any]:
    raise UserError(
        f"{p}: a bare network needs --features SPEC naming its inputs (and their ranges or --calib)"
    )


def _is_torchscript(p: Path) -> bool:
    """TorchScript archives are zips with a constants.pkl and a code/ folder."""
    import zipfile

    if not zipfile.is_zipfile(p):
        return False
    with zipfile.ZipFile(p) as z:
        return any(n.endswith("constants.pkl") for n in z.namelist())


def _torch_load(p: Path) -> Any:
    import warnings

    import torch

    try:
        if _is_torchscript(p):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DeprecationWarning)  # jit.load is the way to read TorchScript
                return torch.jit.load(str(p), map_location="cpu")
        return torch.load(p, map_location="cpu", weights_only=False)
    except Exception as e:  # torch raises many types for unreadable files
        raise UserError(f"{p}: not a readable torch or TorchScript file: {e}") from None
