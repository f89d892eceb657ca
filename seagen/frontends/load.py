"""Read a model file (seagen model.pt, torch module, TorchScript, .pt2, ONNX) into the float IR."""

from __future__ import annotations

import codecs
import dataclasses
import json
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from seagen.actuator import Actuator
from seagen.errors import UserError, not_a_file
from seagen.filekind import ONNX, UNKNOWN, file_kind
from seagen.frontends import Network, read_module, read_onnx
from seagen.frontends import modeldict as D
from seagen.frontends.margin import forward_margin, rounding_margin
from seagen.frontends.torch_files import load_torch
from seagen.ir import FloatLayer, FloatMLP, FloatModel, FloatSF, Signal, poly2
from seagen.modelfile import FORMAT, FeatureSpec, model_actuator
from seagen.quant.qformat import widened, widened_box

UNITS = {"pot": "count", "enc": "count", "angle_deg": "deg", "compression_mm": "mm", "force_n": "N"}


def unit_of(name: str) -> str:
    """Physical unit of a feature name (differences are per sample: one control-loop tick)."""
    base = name.removeprefix("dd_").removeprefix("d_")
    return UNITS.get(base, "")


def fold_normalization(layers: list[FloatLayer], spec: FeatureSpec, where: str = "model") -> list[FloatLayer]:
    """Fold x_model = (x - mean)/std * w into the first layer and y = y_m * std + mean into the last."""
    scale = np.array(spec.weights()) / np.array(spec.std)
    first = layers[0]
    if first.weight.shape[1] != len(spec.inputs):
        raise UserError(
            f"{where}: the first layer takes {first.weight.shape[1]} inputs but the feature specification "
            f"names {len(spec.inputs)} ({', '.join(spec.inputs)})"
        )
    w1 = first.weight * scale[None, :]
    b1 = first.bias - first.weight @ (np.array(spec.mean) * scale)
    out = [dataclasses.replace(first, weight=w1, bias=b1), *layers[1:]]
    last = out[-1]
    if last.activation == "linear":
        out[-1] = FloatLayer(last.weight * spec.output_std, last.bias * spec.output_std + spec.output_mean)
    elif spec.output_std != 1.0 or spec.output_mean != 0.0:
        out.append(FloatLayer(np.array([[spec.output_std]]), np.array([spec.output_mean])))
    if out[-1].weight.shape[0] != 1:
        raise UserError(
            f"{where}: the model has {out[-1].weight.shape[0]} outputs; seagen exports one-output models"
        )
    return out


def signals(spec: FeatureSpec, ranges: Any, units: Any, where: str) -> tuple[Signal, ...]:
    """Input signals with their calibrated ranges (a list of [lo, hi], or a function of the input names:
    --calib); a missing or bad range or unit is an error naming the field."""
    names = list(spec.inputs)
    if ranges is None:
        raise UserError(f"{where}: no calibrated input range (give --calib DATA_DIR or 'input_range')")
    if callable(ranges):
        box = [(float(lo), float(hi)) for lo, hi in ranges(names)]
        for n, (lo, hi) in zip(names, box, strict=True):
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise UserError(f"{where}: input '{n}' has an invalid range [{lo}, {hi}] (needs lo < hi)")
    else:
        box = D.ranges(ranges, len(names), where)
    unit = D.units(units, len(names), where) if units else [unit_of(n) for n in names]
    return tuple(Signal(n, u, lo, hi) for n, (lo, hi), u in zip(names, box, unit, strict=True))


@dataclass
class Loaded:
    """A float model and the original it came from, run by its own runtime on physical inputs."""

    model: FloatModel
    original: Callable[[np.ndarray], np.ndarray]  # physical inputs (N, n_in) float64 -> outputs (N,)
    runtime: str
    margin: float  # stated allowance for the original's own rounding (its float type's forward error)
    dtype: str = "float64"  # the float type the original computes in (the margin derives from it)
    notes: list[str] = dataclasses.field(default_factory=list)  # how the file was read, when not literally
    # the description a seagen model file recorded (the paper's for a file from before the record); None for
    # a bare network or an ONNX graph, which record none
    actuator: Actuator | None = None


def _sf_model(d: dict[str, Any], where: str, rng: Any, output: Signal, task: str) -> Loaded:
    """A seagen surface fit; the original is the polynomial in float64 from its coefficients."""
    names, powers, coef_t = D.sf_fields(d.get("sf"), where)
    coef = np.array(coef_t)
    a, b = signals(FeatureSpec(names, (0.0, 0.0), (1.0, 1.0)), rng, d.get("input_units"), where)
    model = FloatSF((a, b), output, powers, coef_t, task)

    def poly(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        return poly2(powers, coef, x[:, 0], x[:, 1])

    box = [widened(s.lo, s.hi) for s in (a, b)]
    am, bm = (max(abs(lo), abs(hi)) for lo, hi in box)
    size = float(poly2(powers, np.abs(coef), am, bm))  # the largest term magnitudes over the box
    return Loaded(model, poly, "float64 polynomial from the coefficients", 2.0**-40 * (1.0 + size), "float64")


def _mlp_model(
    net: Network, spec: FeatureSpec, d: dict[str, Any], where: str, rng: Any, out: Signal, task: str
) -> Loaded:
    """A network with its feature normalisation folded in; the original runs the network between the
    normalisation and de-normalisation the spec states."""
    layers = fold_normalization(net.layers, spec, where)
    model = FloatMLP(signals(spec, rng, d.get("input_units"), where), out, tuple(layers), task)
    mean, std = np.array(spec.mean), np.array(spec.std)
    w = np.array(spec.weights())

    def original(x: np.ndarray) -> np.ndarray:
        y = net.run((np.asarray(x, dtype=np.float64) - mean) / std * w)
        return y[:, 0] * spec.output_std + spec.output_mean

    box = np.array(widened_box(model.inputs))
    xmax = np.max(np.abs((box - mean) / std * w), axis=0)
    _deterministic(net, xmax, where)
    margin = forward_margin(net.layers, xmax, net.dtype, where) * spec.output_std
    notes = list(net.notes)
    if net.wide is not None:  # float16/bfloat16: the margin from the original's own rounding on the box
        ends = (box - mean) / std * w
        lo, hi = ends.min(axis=0), ends.max(axis=0)
        got = rounding_margin(net.run, net.wide, lo, hi, net.layers, net.wide_whole)
        if got is not None:
            margin = got.margin * abs(spec.output_std)
            notes.append(got.note(net.dtype, abs(spec.output_std), out.unit))
    return Loaded(model, original, net.runtime, margin, net.dtype, notes)


def _deterministic(net: Network, xmax: np.ndarray, where: str) -> None:
    """The original gives the same outputs twice on the same inputs (an oracle that draws random numbers,
    e.g. Dropout left in training mode, cannot check anything)."""
    x = np.random.default_rng(0).uniform(-1.0, 1.0, (16, net.n_in)) * np.maximum(xmax, 1e-3)
    a, b = net.run(x), net.run(x)
    if not np.array_equal(a, b, equal_nan=True):
        raise UserError(
            f"{where}: the model gives different outputs for the same inputs on two runs (Dropout or another "
            "random op active at inference?); seagen exports deterministic models (save it in eval mode)"
        )


def from_model_dict(d: dict[str, Any], where: str, ranges: Any = None, net: Network | None = None) -> Loaded:
    """Float IR (and the original) from a seagen model dict or a bare network with a features dict; every
    field is checked (seagen.frontends.modeldict) before it is used."""
    rng = ranges if ranges is not None else d.get("input_range")
    output = D.output_signal(d, where)
    task = D.task(d, where)
    if D.kind(d, where) == "sf":
        return _sf_model(d, where, rng, output, task)
    if not d.get("features"):
        raise UserError(f"{where}: no feature specification (give --features SPEC)")
    spec = FeatureSpec.from_dict(d["features"], where)
    if net is None:
        net = read_module(d.get("module"), Path(where), len(spec.inputs))
    return _mlp_model(net, spec, d, where, rng, output, task)


def read_features_file(path: str | None) -> dict[str, Any]:
    """A --features SPEC file (JSON or TOML) -> dict with 'features' and optional range/unit keys, every
    field checked, errors naming the file and the field."""
    if path is None:
        return {}
    p = Path(path)
    if not p.is_file():
        raise UserError(not_a_file(p, "feature specification file"))
    content = spec_text(p)
    try:
        raw = tomllib.loads(content) if p.suffix.lower() == ".toml" else json.loads(content)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError, RecursionError) as e:
        raise UserError(f"{p}: cannot parse: {e}") from None
    if not isinstance(raw, dict):
        raise UserError(
            f"{p}: the feature specification must be a JSON object or TOML table, not a {type(raw).__name__}"
        )
    keys = D.SPEC_KEYS
    out = {k: raw[k] for k in keys if k in raw}
    out["features"] = {k: v for k, v in raw.items() if k not in keys}
    known = {f.name for f in dataclasses.fields(FeatureSpec)}
    unknown = sorted(set(out["features"]) - known)
    if unknown:
        raise UserError(
            f"{p}: unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(known | set(keys)))})"
        )
    spec = FeatureSpec.from_dict(out["features"], str(p))
    D.spec_extras(out, len(spec.inputs), str(p))
    return out


def spec_text(p: Path) -> str:
    """A spec file's text: UTF-8, with or without the byte order mark editors write (Notepad), or UTF-16
    with its byte order mark (Notepad's 'Unicode')."""
    try:
        data = p.read_bytes()
    except OSError as e:
        raise UserError(f"{p}: cannot read: {e.strerror or e}") from None
    utf16 = data[:2] in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)
    try:
        return data.decode("utf-16" if utf16 else "utf-8-sig")
    except UnicodeDecodeError as e:
        enc = "UTF-16" if utf16 else "UTF-8"
        raise UserError(
            f"{p}: not a text file (JSON or TOML in {enc}): byte {e.start} is not {enc}"
        ) from None


def load_float_model(
    path: str, features: str | dict[str, Any] | None = None, ranges: Any = None, allow_pickle: bool = False
) -> FloatModel:
    """Any supported model file -> float IR (a features file overrides/fills the model's own metadata).

    `ranges` (a list of [lo, hi] or a function of the input names returning one) overrides the model's own
    calibrated input ranges.
    """
    return load_with_original(path, features, ranges, allow_pickle).model


def load_with_original(
    path: str, features: str | dict[str, Any] | None = None, ranges: Any = None, allow_pickle: bool = False
) -> Loaded:
    """The float IR of a model file and its original run by its own runtime (for the oracle); `features`:
    a --features file, or the dict `read_features_file` made of one."""
    p = Path(path)
    if not p.is_file():
        raise UserError(not_a_file(p, "model file"))
    extra = features if isinstance(features, dict) else read_features_file(features)
    kind = file_kind(p)
    if kind == UNKNOWN:
        raise UserError(
            f"{p}: not a model file seagen reads (by its content it is neither an ONNX model, a readable zip "
            "archive nor a torch pickle)"
        )
    if kind == ONNX:
        if not extra:
            _need_features(p)
        return from_model_dict({"kind": "mlp", **extra}, str(p), ranges, read_onnx(p))
    obj = load_torch(p, allow_pickle)
    if isinstance(obj, dict) and obj.get("format") == FORMAT:
        loaded = from_model_dict({**obj, **extra}, str(p), ranges)
        return dataclasses.replace(loaded, actuator=model_actuator(obj, str(p)))
    if isinstance(obj, dict):
        from seagen.modelfile import describe_dict

        raise UserError(describe_dict(obj, p, FORMAT))
    if not extra:
        _need_features(p)
    return from_model_dict({"kind": "mlp", **extra, "module": obj}, str(p), ranges)


def _need_features(p: Path) -> dict[str, Any]:
    raise UserError(
        f"{p}: a bare network needs --features SPEC naming its inputs (and their ranges or --calib)"
    )
