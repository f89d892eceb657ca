"""`seagen export`, the pipeline: model file -> float IR -> quantized IR -> C, checked by the oracle, written
atomically. A driver at the top of the package graph (it uses frontends, quant, reference, codegen, build)."""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from seagen.actuator import Actuator
from seagen.atomic import locked_folder, writable_place
from seagen.cnames import assert_valid_prefix, identifier_from
from seagen.codegen.actfile import export_actuator
from seagen.codegen.cmake import DEFAULT_PACKAGE, check_folder_package, cmake_files
from seagen.codegen.manifest import SUFFIX, manifest_text
from seagen.codegen.packaging import SKETCH_VECTORS, shared_files, sketch
from seagen.codegen.quant_summary import summary_lines
from seagen.codegen.render import RUNTIME, model_hash, render
from seagen.codegen.runtime import runtime_sources
from seagen.codegen.targets import OMIT, check_target
from seagen.codegen.targets import RUNTIME as TARGET_RUNTIME
from seagen.errors import CheckFailed, UserError
from seagen.frontends.load import Loaded, load_with_original, read_features_file
from seagen.ir import QMLP, FloatMLP, FloatModel, QModel
from seagen.quant.affine import tighten
from seagen.quant.model import quantize
from seagen.reference.oracle import OracleReport, box_points, compare_original
from seagen.runtime.actq import ActQ, act_q

BOUND_GOAL = 10.0  # an MLP's proven bound is refined until within this factor of the error the oracle saw


@dataclass
class Export:
    """What an export produced: the float and quantized models, the files, the summary and the oracle."""

    loaded: Loaded = field(repr=False)  # the float IR and the original model run by its own runtime
    qmodel: QModel
    prefix: str
    files: dict[str, str]
    oracle: OracleReport
    onnx_bytes: bytes | None = None
    lines: list[str] = field(default_factory=list)
    act: ActQ | None = None  # the actuator's proven constants (its sea_act_<id> file)
    actuator: Actuator | None = None  # its description
    package: str = DEFAULT_PACKAGE  # the CMake package of its folder (seagen::NAME)
    # the package's files in sub-folders (zephyr/module.yml, examples/NAME/NAME.ino): written and hashed with
    # the export, kept apart from `files`, the flat folder the C builds compile
    tree: dict[str, str] = field(default_factory=dict)

    @property
    def float_model(self) -> FloatModel:
        """The float IR the quantized model approximates."""
        return self.loaded.model


def calib_ranges(data_dir: str, names: list[str]) -> list[list[float]]:
    """Observed [min, max] of each named feature on the training split of a data directory (its features on
    the actuator the data were recorded on)."""
    from seagen.data.features import derive
    from seagen.data.schema import data_actuator, load_split
    from seagen.geometry import geometry

    df = derive(load_split(data_dir, "train"), geometry(data_actuator(data_dir)))
    missing = [n for n in names if n not in df.columns]
    if missing:
        raise UserError(f"{data_dir}: cannot compute a calibration range for {', '.join(missing)}")
    return [[float(df[n].min()), float(df[n].max())] for n in names]


def default_prefix(model_path: str) -> str:
    """A C identifier from the model file name (e.g. mlp_calibration.pt -> mlp_calibration)."""
    return identifier_from(Path(model_path).stem)


def prepare(
    model_path: str,
    prefix: str | None = None,
    weights: str = "int16",
    calib: str | None = None,
    features: str | dict[str, Any] | None = None,
    with_onnx: bool = False,
    allow_pickle: bool = False,
    controller: bool | None = False,
    ranges: list[list[float]] | None = None,
    target: str = "portable",
    actuator: Actuator | None = None,
    package: str | None = None,
) -> Export:
    """Everything of an export, in memory (nothing is written); refuses (CheckFailed) when the integer
    reference and the original model disagree beyond the proven bound on the calibrated box.

    `controller` adds NAME_controller.{h,c} and the controller runtime (control models; None: when the model
    is one); `ranges` gives the
    input ranges outright (seagen verify rebuilds an export from its manifest that way); `target` picks the
    kernel of NAME_infer (seagen/codegen/targets.py) and the runtime header it includes; `features` is a
    --features file or the spec already read from one (a manifest's); `actuator`: a description given with
    --actuator (the model file's own is used; a disagreeing one is refused); `package`: the CMake library
    seagen::NAME of the folder (CMakeLists.txt, codegen/cmake.py; default models)."""
    package = DEFAULT_PACKAGE if package is None else package
    prefix = assert_valid_prefix(default_prefix(model_path) if prefix is None else prefix)
    bits = {"int16": 16, "int8": 8}.get(weights)
    if bits is None:
        raise UserError(f"--weights must be int16 or int8, not {weights!r}")
    given = ranges or ((lambda names: calib_ranges(calib, names)) if calib else None)
    spec = features if isinstance(features, dict) else read_features_file(features)
    loaded = load_with_original(model_path, spec, given, allow_pickle)
    try:
        qm = quantize(loaded.model, bits)
    except UserError as e:  # a range or a weight that cannot be represented: name the file
        raise UserError(str(e) if str(e).startswith(model_path) else f"{model_path}: {e}") from None
    rep = compare_original(
        f"oracle ({loaded.runtime}) on the box", qm, loaded.original, box_points(qm), loaded.margin
    )
    if not rep.ok:
        raise CheckFailed(f"{model_path}: {rep.line()}")
    qm, rep = _tightened(loaded, qm, rep, model_path)
    act = export_actuator(loaded, actuator, model_path)
    aq = act_q(act)  # the geometry's formats proven, or refused with the reason
    try:
        rendered = render(qm, prefix, target, aq)
    except UserError as e:  # a name or text the C cannot hold (the loaders refuse these first)
        raise UserError(f"{model_path}: {e}") from None
    shipped = [n for n in RUNTIME if n not in OMIT[check_target(target)]]
    files = {**rendered, **runtime_sources(*shipped, *TARGET_RUNTIME[target])}
    if controller is None:
        from seagen.runtime.features import is_predictor

        controller = is_predictor(qm)
    if controller:
        from seagen.codegen.controller import controller_files

        files.update(controller_files(prefix, qm, act=aq))
    files.update(cmake_files(prefix, files, package))
    package_part = package_files(qm, prefix, package)
    files.update({n: t for n, t in package_part.items() if "/" not in n})
    tree = {n: t for n, t in package_part.items() if "/" in n}
    onnx_bytes = None
    if with_onnx:
        from seagen.reference.onnx_ref import build_onnx

        onnx_bytes = build_onnx(qm, prefix).SerializeToString()
    options = {"weights": weights, "target": target, "calib": calib, "onnx": with_onnx}
    options |= {"controller": controller, "package": package}
    if allow_pickle:  # recorded only when used: torch's own readers opened the file, past the allow-list
        options["allow_pickle"] = True
    original = {"runtime": loaded.runtime, "dtype": loaded.dtype, "margin": float(f"{loaded.margin:.6g}")}
    # the proven bound over the largest |integer - original| the oracle saw (issue 38, item 5)
    original["bound_over_measured"] = (
        float(f"{qm.error_bound / rep.max_err:.4g}") if rep.max_err > 0 else None
    )
    files[f"{prefix}{SUFFIX}"] = export_manifest(
        qm, prefix, model_path, options, spec, {**files, **tree}, onnx_bytes, original, aq
    )
    lines = [*loaded.notes, *summary_lines(qm), f"actuator '{act.name}' (sha256 {aq.digest[:12]}): {aq.cid}"]
    return Export(loaded, qm, prefix, files, rep, onnx_bytes, lines, aq, act, package, tree)


def package_files(qm: QModel, prefix: str, package: str) -> dict[str, str]:
    """The Zephyr, ESP-IDF, PlatformIO and Arduino files of the folder's package (codegen/packaging.py) and
    the Arduino example of this export: NAME_infer on recorded rows (in and around the calibrated box) with
    the integer reference's outputs."""
    from seagen.reference import numpy_ref
    from seagen.toolchain.equivalence import random_inputs

    rows = random_inputs(qm, SKETCH_VECTORS, seed=37).astype(np.int64)
    outs = numpy_ref.infer(qm, rows).reshape(len(rows), -1)
    return {**shared_files(package), **sketch(prefix, rows.tolist(), outs.tolist())}


def _tightened(loaded: Loaded, qm: QModel, rep: OracleReport, model_path: str) -> tuple[QModel, OracleReport]:
    """An MLP's proven bound refined (seagen.quant.affine.tighten) until it is within BOUND_GOAL x the error
    the oracle measured, and the oracle's verdict against that bound."""
    fm = loaded.model
    if not isinstance(qm, QMLP) or not isinstance(fm, FloatMLP) or not rep.max_err > 0:
        return qm, rep
    if qm.error_bound <= BOUND_GOAL * rep.max_err:
        return qm, rep
    qm = tighten(fm, qm, BOUND_GOAL * rep.max_err)
    x = box_points(qm)
    rep = compare_original(f"oracle ({loaded.runtime}) on the box", qm, loaded.original, x, loaded.margin)
    if not rep.ok:
        raise CheckFailed(f"{model_path}: {rep.line()}")
    return qm, rep


def export_manifest(
    qm: QModel,
    prefix: str,
    model_path: str,
    options: dict,
    spec: dict[str, Any],
    files: dict[str, str],
    onnx_bytes: bytes | None,
    original: dict[str, Any] | None = None,
    act: ActQ | None = None,
) -> str:
    """NAME.seagen.json for the files of this export (the runtime files and NAME.onnx included); `spec`:
    the --features file as read ({} without one); `original`: the oracle's runtime, the original's float
    type and the margin its rounding is allowed on top of the proven bound."""
    emitted = {name: text.encode() for name, text in files.items()}
    if onnx_bytes is not None:
        emitted[f"{prefix}.onnx"] = onnx_bytes
    resolved = {
        "inputs": [[i.signal.name, i.signal.unit, i.signal.lo, i.signal.hi] for i in qm.inputs],
        "output": [qm.output.name, qm.output.unit],
        "qmodel_hash": model_hash(qm),
        "error_bound": qm.error_bound,
        "features": spec or None,
    }
    if original is not None:
        resolved["original"] = original
    if act is not None:  # the description the geometry file was emitted from (seagen verify checks it)
        resolved["actuator"] = {"name": act.name, "sha256": act.digest, "file": f"{act.cid}.c"}
    return manifest_text(prefix, model_path, options, resolved, emitted)


def check_out_dir(out_dir: str | os.PathLike[str]) -> Path:
    """The output folder: an existing writable directory, or a path whose nearest existing parent is one."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a directory (--out needs a folder)")
    if why := writable_place(out / "x"):
        raise UserError(f"{out}: {why}" + (" (--out needs a folder)" if "a file" in why else ""))
    return out


def write(ex: Export, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write all files atomically: staged in a temporary folder, then renamed in under a lock on the folder
    (a second export into it waits), the manifest last. A NAME.onnx or NAME_controller.{h,c} from an
    earlier export that this one does not write is removed (it would describe another model or
    configuration). Other exports in the folder are not touched (the shared runtime and CMake files they also
    use are rewritten with the same text)."""
    out = check_out_dir(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
        stage = Path(tempfile.mkdtemp(dir=out, prefix=".export."))
    except OSError as e:
        raise UserError(f"{out}: cannot write the export: {e.strerror or e}") from None
    try:
        for name, text in {**ex.files, **ex.tree}.items():
            (stage / name).parent.mkdir(parents=True, exist_ok=True)
            (stage / name).write_text(text)
        if ex.onnx_bytes is not None:
            (stage / f"{ex.prefix}.onnx").write_bytes(ex.onnx_bytes)
        manifest = f"{ex.prefix}{SUFFIX}"
        staged = (f.relative_to(stage).as_posix() for f in stage.rglob("*") if f.is_file())
        names = sorted(n for n in staged if n != manifest) + [manifest]
        own = (f"{ex.prefix}.onnx", f"{ex.prefix}_controller.h", f"{ex.prefix}_controller.c")
        with locked_folder(out):  # the folder's package checked under the lock another export waits on
            check_folder_package(out, ex.prefix, ex.package)
            for name in names[:-1]:
                (out / name).parent.mkdir(parents=True, exist_ok=True)
                os.replace(stage / name, out / name)
            for name in set(own) - set(names):  # left by an earlier export of NAME
                (out / name).unlink(missing_ok=True)
            os.replace(stage / manifest, out / manifest)
        return [out / name for name in sorted(names)]
    except OSError as e:
        raise UserError(f"{out}: cannot write the export: {e.strerror or e}") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
