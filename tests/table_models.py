"""Models from real producers for the model table: torch (pickled, scripted, traced, .pt2, ONNX exporters),
skl2onnx, hand-built ONNX graphs, and malicious files. Each builder writes its file(s) and returns a Row."""

from __future__ import annotations

import io
import json
import warnings
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import onnx
import torch
import torch.nn.functional as F
from onnx import TensorProto, helper, numpy_helper
from torch import nn

N_IN, HIDDEN = 3, 8
NAMES = ["pot", "enc", "d_enc"]
RANGE = [[1000.0, 3000.0], [0.0, 5000.0], [-50.0, 50.0]]
MEAN = [2000.0, 2500.0, 0.0]
STD = [600.0, 1500.0, 20.0]
OUT_MEAN, OUT_STD = 5.0, 4.0
MARKER = "payload_ran"


@dataclass
class Row:
    """One table row: the arguments after MODEL, what must happen, and the original to check against."""

    args: list[str]
    expect: str  # "export" or "refuse"
    code: int = 0
    message: str = ""
    original: Callable[[np.ndarray], np.ndarray] | None = field(default=None, repr=False)  # normalised in
    marker: Path | None = None


def spec_file(d: Path) -> Path:
    """The --features file every bare network of the table uses."""
    p = d / "features.json"
    spec = {
        "inputs": NAMES, "mean": MEAN, "std": STD, "output_mean": OUT_MEAN, "output_std": OUT_STD,
        "input_range": RANGE, "output_name": "force_n", "output_units": "N",
    }  # fmt: skip
    p.write_text(json.dumps(spec))
    return p


def torch_original(m: nn.Module) -> Callable[[np.ndarray], np.ndarray]:
    """The module's own forward (eval, float32) on normalised inputs."""
    m.eval()

    def run(x: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return m(torch.from_numpy(np.asarray(x, np.float32))).double().numpy().reshape(len(x), -1)[:, 0]

    return run


def ort_original(path: Path, dtype=np.float32) -> Callable[[np.ndarray], np.ndarray]:
    """onnxruntime on the file as written: rows laid out as its input (a symbolic dimension takes them all;
    a fixed shape takes its rows one run each, e.g. a (features,) input one row, a batch fixed at 4 the
    row repeated)."""
    import onnxruntime as ort

    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    inp = sess.get_inputs()[0]
    shape = inp.shape
    open_dim = next((i for i, d in enumerate(shape) if not isinstance(d, int)), None)
    fixed_rows = int(np.prod(shape)) // N_IN if open_dim is None else 0

    def once(x: np.ndarray) -> np.ndarray:
        layout = [len(x) if i == open_dim else d for i, d in enumerate(shape)]
        y = sess.run(None, {inp.name: np.asarray(x, dtype).reshape(layout)})[0]
        return np.asarray(y, float).reshape(len(x), -1)[:, 0]

    def run(x: np.ndarray) -> np.ndarray:
        if open_dim is not None:
            return once(x)
        rows = [once(np.repeat(x[i : i + 1], fixed_rows, axis=0))[:1] for i in range(len(x))]
        return np.concatenate(rows)

    return run


def _init(m: nn.Module, seed: int) -> nn.Module:
    """Deterministic weights, and BatchNorm statistics that are not the identity."""
    torch.manual_seed(seed)
    for p in m.modules():
        if isinstance(p, nn.Linear):
            nn.init.uniform_(p.weight, -0.8, 0.8)
            nn.init.uniform_(p.bias, -0.3, 0.3)
        if isinstance(p, nn.BatchNorm1d):
            p.running_mean.uniform_(-0.5, 0.5)
            p.running_var.uniform_(0.5, 2.0)
            nn.init.uniform_(p.weight, 0.5, 1.5)
            nn.init.uniform_(p.bias, -0.2, 0.2)
    return m.eval()


def seq(*mid: nn.Module, seed: int = 0) -> nn.Sequential:
    """Linear(3, 8), the given layers, Linear(8, 1)."""
    return _init(nn.Sequential(nn.Linear(N_IN, HIDDEN), *mid, nn.Linear(HIDDEN, 1)), seed)  # type: ignore[return-value]


class Functional(nn.Module):
    """A custom module whose forward calls functional activations (nothing registered as a layer)."""

    def __init__(self, act: str = "relu") -> None:
        super().__init__()
        self.act = act
        self.fc1, self.fc2, self.out = (
            nn.Linear(N_IN, HIDDEN),
            nn.Linear(HIDDEN, HIDDEN),
            nn.Linear(HIDDEN, 1),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = F.relu(self.fc1(x))
        h = torch.tanh(self.fc2(h)) if self.act == "tanh" else F.leaky_relu(self.fc2(h), 0.1)
        return self.out(h)


class Lambda(nn.Module):
    """A module whose forward is a given function of (self, x) (for graphs a Sequential cannot express)."""

    def __init__(self, kind: str) -> None:
        super().__init__()
        self.kind = kind
        self.fc1, self.fc2, self.out = (
            nn.Linear(N_IN, HIDDEN),
            nn.Linear(HIDDEN, HIDDEN),
            nn.Linear(HIDDEN, 1),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = F.relu(self.fc1(x))
        k = self.kind
        if k == "affine_after_act":
            return self.out(torch.sigmoid(self.fc2(h * 2.0 + 1.0)) - 0.5)
        if k == "affine_after_last":
            return torch.tanh(self.out(h)) * 3.0 - 1.0
        if k == "residual":
            return self.out(h + F.relu(self.fc2(h)))
        if k == "shared":
            return self.out(F.relu(self.fc2(F.relu(self.fc2(h)))))
        if k == "stacked":
            return self.out(torch.tanh(F.relu(self.fc2(h))))
        if k == "clamp_min":
            return self.out(torch.clamp(self.fc2(h), min=-0.3))
        if k == "clamp_max":
            return self.out(torch.clamp(self.fc2(h), max=0.4))
        if k == "alpha_arith":  # add/rsub/sub with alpha, a constant built from torch.ones
            g = torch.rsub(torch.add(self.fc2.bias, F.relu(self.fc2(h)), alpha=2.0), 1.0, alpha=0.5)
            return self.out(torch.sub(3.0 * torch.ones(8), g, alpha=1.5)) / 2 - 1
        if k == "celu":  # an activation seagen does not read
            return self.out(F.celu(self.fc2(h)))
        if k == "addmm_scaled":  # addmm's beta and alpha scale the bias and the product
            return self.out(torch.addmm(self.fc2.bias, h, self.fc2.weight.t(), beta=0.5, alpha=2.0))
        if k == "add_self":
            return self.out(h + h)
        if k == "mul_self":
            return self.out(h * h)
        if k == "leaky_negative":
            return self.out(F.leaky_relu(self.fc2(h), -0.5))
        if k == "leaky_steep":
            return self.out(F.leaky_relu(self.fc2(h), 1.5))
        if k == "clamp_inverted":  # min > max: every output is max
            return self.out(torch.clamp(self.fc2(h), min=0.5, max=-0.2))
        return self.out(F.hardtanh(self.fc2(h), -0.6, 0.6) * 0.5 + 0.25)


class Dropped(nn.Module):
    """Linear, ReLU, Dropout, Linear with a custom forward (for TorchScript saved in training mode)."""

    def __init__(self) -> None:
        super().__init__()
        self.fc1, self.drop, self.out = nn.Linear(N_IN, HIDDEN), nn.Dropout(0.5), nn.Linear(HIDDEN, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(self.drop(F.relu(self.fc1(x))))


class Payload:
    """Pickling this calls Path.touch(marker) on load: what a malicious model file does."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):  # noqa: D105
        return (Path.touch, (self.marker,))


def _quiet(fn: Callable, *a, **k):
    """Call a torch exporter with its warnings silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*a, **k)


def example() -> tuple[torch.Tensor]:
    """An example batch for tracing and exporting."""
    return (torch.zeros(4, N_IN),)


def pt2_with_bad_sample(src: Path, dst: Path, marker: Path) -> None:
    """A .pt2 archive whose sample inputs are a malicious pickle."""
    bad = io.BytesIO()
    torch.save({"x": Payload(marker)}, bad)
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for info in zin.infolist():
            data = bad.getvalue() if "/sample_inputs/" in info.filename else zin.read(info.filename)
            zout.writestr(info, data)


def onnx_model(
    nodes: list,
    inits: dict[str, np.ndarray],
    out: str = "y",
    extra_inputs=(),
    opset: int = 17,
    batch: int | str = "N",
    dtype=np.float32,
):
    """A float ONNX graph with input 'x' (batch, 3) and output `out` (batch, 1); `batch` a number fixes it."""
    elem = helper.np_dtype_to_tensor_dtype(np.dtype(dtype))
    graph = helper.make_graph(
        nodes,
        "g",
        [helper.make_tensor_value_info("x", elem, [batch, N_IN]), *extra_inputs],
        [helper.make_tensor_value_info(out, elem, [batch, 1])],
        [
            numpy_helper.from_array(np.asarray(v, np.int64 if k == "SHAPE" else dtype), k)
            for k, v in inits.items()
        ],
    )
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)])


def weights(seed: int) -> dict[str, np.ndarray]:
    """W1 (8, 3), B1 (8,), W2 (1, 8), B2 (1,) as (out, in) matrices."""
    rng = np.random.default_rng(seed)
    return {
        "W1": rng.uniform(-0.8, 0.8, (HIDDEN, N_IN)), "B1": rng.uniform(-0.3, 0.3, HIDDEN),
        "W2": rng.uniform(-0.8, 0.8, (1, HIDDEN)), "B2": rng.uniform(-0.3, 0.3, 1),
    }  # fmt: skip


def gemm_graph(form: str, seed: int):
    """Two dense layers with ReLU between, the first written in one Gemm/MatMul form."""
    w = weights(seed)
    n2 = helper.make_node("Gemm", ["r", "W2", "B2"], ["y"], transB=1)
    relu = helper.make_node("Relu", ["h"], ["r"])
    if form == "transB0":
        first = [helper.make_node("Gemm", ["x", "W1T", "B1"], ["h"])]
        inits = {"W1T": w["W1"].T, "B1": w["B1"]}
    elif form == "alpha_beta":
        first = [helper.make_node("Gemm", ["x", "W1", "B1"], ["h"], transB=1, alpha=0.5, beta=2.0, transA=0)]
        inits = {"W1": w["W1"] * 2.0, "B1": w["B1"] / 2.0}
    elif form == "bias_1n":
        first = [helper.make_node("Gemm", ["x", "W1", "B1"], ["h"], transB=1)]
        inits = {"W1": w["W1"], "B1": w["B1"][None, :]}
    elif form == "no_bias":
        first = [helper.make_node("Gemm", ["x", "W1"], ["h"], transB=1)]
        inits = {"W1": w["W1"]}
    else:  # matmul_add with a (1, N) bias on the left of the Add
        first = [helper.make_node("MatMul", ["x", "W1T"], ["m"]), helper.make_node("Add", ["B1", "m"], ["h"])]
        inits = {"W1T": w["W1"].T, "B1": w["B1"][None, :]}
    return onnx_model([*first, relu, n2], {**inits, "W2": w["W2"], "B2": w["B2"]})


def graph_case(kind: str, seed: int):
    """Hand-built graphs: affine after activation, stacked activations, clips, residual, weight input, dead
    branch, nodes listed out of order."""
    w = weights(seed)
    base = {"W1": w["W1"], "B1": w["B1"], "W2": w["W2"], "B2": w["B2"]}
    g1 = helper.make_node("Gemm", ["x", "W1", "B1"], ["h"], transB=1)
    g2 = helper.make_node("Gemm", ["a", "W2", "B2"], ["y"], transB=1)
    if kind == "add_after_relu":
        mid = [helper.make_node("Relu", ["h"], ["r"]), helper.make_node("Add", ["r", "C"], ["a"])]
        return onnx_model([g1, *mid, g2], {**base, "C": np.full(HIDDEN, 0.7)})
    if kind == "stacked":
        mid = [helper.make_node("Relu", ["h"], ["r"]), helper.make_node("Tanh", ["r"], ["a"])]
        return onnx_model([g1, *mid, g2], base)
    if kind == "clip_min":
        return onnx_model([g1, helper.make_node("Clip", ["h", "LO"], ["a"]), g2], {**base, "LO": -0.2})
    if kind == "clip_max":
        return onnx_model([g1, helper.make_node("Clip", ["h", "", "HI"], ["a"]), g2], {**base, "HI": 0.3})
    if kind == "clip_inverted":  # min > max: ONNX defines every output as max
        node = helper.make_node("Clip", ["h", "LO", "HI"], ["a"])
        return onnx_model([g1, node, g2], {**base, "LO": 0.4, "HI": -0.1})
    if kind == "clip_shape_1":  # bounds of shape (1,), which onnxruntime runs
        node = helper.make_node("Clip", ["h", "LO", "HI"], ["a"])
        return onnx_model([g1, node, g2], {**base, "LO": [-0.2], "HI": [0.3]})
    if kind == "leaky_negative":
        return onnx_model([g1, helper.make_node("LeakyRelu", ["h"], ["a"], alpha=-0.4), g2], base)
    if kind == "leaky_steep":
        return onnx_model([g1, helper.make_node("LeakyRelu", ["h"], ["a"], alpha=3.0), g2], base)
    if kind == "add_self":
        mid = [helper.make_node("Relu", ["h"], ["r"]), helper.make_node("Add", ["r", "r"], ["a"])]
        return onnx_model([g1, *mid, g2], base)
    if kind == "mul_self":
        mid = [helper.make_node("Relu", ["h"], ["r"]), helper.make_node("Mul", ["r", "r"], ["a"])]
        return onnx_model([g1, *mid, g2], base)
    if kind == "fixed_batch_1":  # a batch of 1 fixed in the input, the output and a Reshape
        mid = [helper.make_node("Relu", ["h"], ["r"]), helper.make_node("Reshape", ["r", "SHAPE"], ["a"])]
        return onnx_model([g1, *mid, g2], {**base, "SHAPE": [1, HIDDEN]}, batch=1)
    if kind == "float16":
        return onnx_model([g1, helper.make_node("Tanh", ["h"], ["a"]), g2], base, dtype=np.float16)
    if kind == "clip_attr":
        node = helper.make_node("Clip", ["h"], ["a"], min=-0.5, max=0.5)
        return onnx_model([g1, node, g2], base, opset=10)
    if kind == "residual":
        mid = [helper.make_node("Relu", ["h"], ["r"]), helper.make_node("Add", ["r", "h"], ["a"])]
        return onnx_model([g1, *mid, g2], base)
    if kind == "weight_input":
        extra = [helper.make_tensor_value_info("W1", TensorProto.FLOAT, [HIDDEN, N_IN])]
        base.pop("W1")
        return onnx_model([g1, helper.make_node("Relu", ["h"], ["a"]), g2], base, extra_inputs=extra)
    if kind == "dead_branch":
        dead = helper.make_node("Sigmoid", ["x"], ["unused"])
        return onnx_model([dead, g1, helper.make_node("Relu", ["h"], ["a"]), g2], base)
    # out of order: the nodes listed last-first
    return onnx_model([g2, helper.make_node("Relu", ["h"], ["a"]), g1], base)


def save_onnx(model, path: Path) -> Path:
    """Write an ONNX model."""
    onnx.save(model, str(path))
    return path


class DeviceAttr(nn.Module):
    """A module holding a torch.device attribute and moving its input there, as LightningModule does (its
    to_torchscript() keeps the device in data.pkl)."""

    def __init__(self) -> None:
        super().__init__()
        self.device = torch.device("cpu")
        self.fc1, self.out = nn.Linear(N_IN, HIDDEN), nn.Linear(HIDDEN, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(torch.tanh(self.fc1(x.to(self.device))))


class TensorConst(nn.Module):
    """A forward that builds its constants with torch.tensor([...]) (a scale list and a scalar offset)."""

    def __init__(self) -> None:
        super().__init__()
        self.fc1, self.out = nn.Linear(N_IN, HIDDEN), nn.Linear(HIDDEN, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        scale = torch.tensor([0.5, 1.0, 1.5, 2.0, -1.0, 0.25, 3.0, 1.0])
        return self.out(F.relu(self.fc1(x)) * scale + torch.tensor(0.125))


class ViewBatch(nn.Module):
    """x.view(x.shape[0], -1) between layers and a reshape to (batch, 1) at the end."""

    def __init__(self) -> None:
        super().__init__()
        self.fc1, self.out = nn.Linear(N_IN, HIDDEN), nn.Linear(HIDDEN, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = F.relu(self.fc1(x.view(x.shape[0], -1)))
        return self.out(h.view(h.shape[0], -1)).reshape(x.shape[0], 1)


class TwoInputs(nn.Module):
    """A forward that takes two tensors, (batch, 2) and (batch, 1), and concatenates them into one vector."""

    def __init__(self) -> None:
        super().__init__()
        self.fc1, self.out = nn.Linear(N_IN, HIDDEN), nn.Linear(HIDDEN, 1)

    def forward(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        return self.out(F.relu(self.fc1(torch.cat([a, b], dim=1))))


def ort_two_inputs(path: Path, width_a: int) -> Callable[[np.ndarray], np.ndarray]:
    """onnxruntime on a graph of two inputs (batch, width_a) and (batch, rest): the row's columns split."""
    import onnxruntime as ort

    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    a, b = (i.name for i in sess.get_inputs())

    def run(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, np.float32)
        y = sess.run(None, {a: x[:, :width_a].copy(), b: x[:, width_a:].copy()})[0]
        return np.asarray(y, float).reshape(len(x), -1)[:, 0]

    return run


class TwoInputsSwapped(nn.Module):
    """TwoInputs taking its inputs the other way round: forward(b, a) concatenates [a, b]."""

    def __init__(self, inner: nn.Module) -> None:
        super().__init__()
        self.inner = inner

    def forward(self, b: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
        return self.inner(a, b)


class RowsJoined(nn.Module):
    """Two (batch, 3) inputs concatenated along the batch (rows of both), then a dense layer."""

    def __init__(self) -> None:
        super().__init__()
        self.fc = nn.Linear(N_IN, 1)

    def forward(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        return self.fc(torch.cat([a, b], dim=0))


def torch_two_inputs(m: nn.Module, width_a: int, swap: bool = False) -> Callable[[np.ndarray], np.ndarray]:
    """The module's own forward on the row's columns split into a (the first width_a) and b (the rest);
    `swap` passes them as (b, a)."""
    m.eval()

    def run(x: np.ndarray) -> np.ndarray:
        t = torch.from_numpy(np.asarray(x, np.float32))
        a, b = t[:, :width_a], t[:, width_a:]
        with torch.no_grad():
            return m(*((b, a) if swap else (a, b))).double().numpy().reshape(len(x), -1)[:, 0]

    return run


class TensorConstMixed(nn.Module):
    """torch.tensor of a list mixing ints and floats (TorchScript types it List[Union[float, int]])."""

    def __init__(self) -> None:
        super().__init__()
        self.fc1, self.out = nn.Linear(N_IN, HIDDEN), nn.Linear(HIDDEN, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(F.relu(self.fc1(x)) * torch.tensor([1.0, 2, 3, 4, 5, 6, 7, 8]))


class HalfRows(nn.Module):
    """A reshape to (batch // 2, -1): values of two rows joined into one (refused)."""

    def __init__(self) -> None:
        super().__init__()
        self.fc1, self.out = nn.Linear(N_IN, HIDDEN), nn.Linear(2 * HIDDEN, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = F.relu(self.fc1(x))
        return self.out(h.reshape(h.shape[0] // 2, -1))
