"""Build the C on disk as it is; compare it bit for bit with MODEL's references rebuilt from the manifest."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from seagen.actuator import Actuator
from seagen.codegen.manifest import Manifest
from seagen.datacheck import check_data_dir
from seagen.defaults import resolve_model
from seagen.errors import CheckFailed, UserError
from seagen.geometry import geometry
from seagen.reference import onnx_ref
from seagen.toolchain.equivalence import compare, edge_inputs, random_inputs, step_problem
from seagen.toolchain.targets import NAMES, build_target
from seagen.verify.constants import constants_problem
from seagen.verify.drift import (
    changed_files,
    check_fields,
    check_files,
    check_model,
    check_stray,
    check_version,
    fields_name,
    select,
)
from seagen.verify.result import Verdict


def rebuild(
    man: Manifest,
    model: Path,
    features: str | None,
    allow_pickle: bool = False,
    with_onnx: bool = False,
    actuator=None,
):
    """The export MODEL gives today with the manifest's resolved options (ranges, features, weights)."""
    from seagen.export import prepare

    opts, res = man.data["options"], man.data["resolved"]
    return prepare(
        str(model),
        man.prefix,
        opts["weights"],
        None,
        features if features is not None else (res.get("features") or {}),
        with_onnx,
        allow_pickle,
        controller=bool(opts.get("controller")),
        target=opts.get("target", "portable"),
        ranges=[[float(lo), float(hi)] for _n, _u, lo, hi in res["inputs"]],
        actuator=actuator,
        package=opts.get("package"),
    )


def disk_files(folder: Path, man: Manifest) -> dict[str, str]:
    """The export's C sources and headers as they are on disk (read once, for every check)."""
    return {n: (folder / n).read_text() for n in man.files if n.endswith((".c", ".h"))}


ENC_BELOW = 0.05  # the synthetic encoder range reaches this fraction of its span below zero (drift)


def enc_span(act: Actuator) -> tuple[float, float]:
    """Encoder counts an actuator's data can span: from home to contact at the top of its linkage range,
    then the compression of the top of its force range (Eq. 2-3), with ENC_BELOW of it below zero."""
    geo = geometry(act)
    mm = (
        float(geo.shaft_advance_mm(act.linkage.angle_max_deg)) + act.control.force_max_n / geo.spring_n_per_mm
    )
    hi = mm / geo.mm_per_count
    return -ENC_BELOW * hi, hi


def synthetic_trials(qm, act: Actuator, n_trials: int = 4, n: int = 400, seed: int = 0):
    """enc, pot, trial ids: bounded random walks inside the calibrated pot/enc ranges (or the sensors' of
    actuator `act`: its pot's ADC range, its encoder's span)."""
    rng = np.random.default_rng(seed)
    rng_of = {i.signal.name: (i.signal.lo, i.signal.hi) for i in qm.inputs}
    plo, phi = rng_of.get("pot", (0.0, float(act.adc_max)))
    elo, ehi = rng_of.get("enc", enc_span(act))
    enc, pot = [], []
    for _ in range(n_trials):
        e = np.clip(elo + np.cumsum(rng.integers(-3, 4, n)) + rng.uniform(0, ehi - elo), elo, ehi)
        p = np.clip(plo + np.cumsum(rng.integers(-6, 7, n)) + rng.uniform(0, phi - plo), plo, phi)
        enc.append(np.rint(e))
        pot.append(np.rint(p))
    trial = np.repeat(np.arange(n_trials), n)
    return np.concatenate(enc).astype(np.int64), np.concatenate(pot).astype(np.int64), trial


def check_steps(v: Verdict, ex, target, data: str | None, onnx_model) -> None:
    """NAME_step on the recorded trials of DATA (test, validation), or on synthetic sequences in the box."""
    from seagen.runtime.features import external_inputs

    qm, p = ex.qmodel, ex.prefix
    ext_names = external_inputs(qm)
    if data is None:
        enc, pot, trial = synthetic_trials(qm, ex.actuator)
        rng = np.random.default_rng(1)
        ext = np.column_stack(
            [rng.integers(qi.lo_q, qi.hi_q + 1, len(enc)) for qi in qm.inputs if qi.signal.name in ext_names]
            or [np.zeros((len(enc), 0), dtype=np.int64)]
        )
        v.add(
            f"{p}_step on synthetic sequences",
            step_problem(qm, target, enc, pot, trial, ext, ex.act),
            info=f"{len(set(trial))} sequences",
        )
        return
    rep = check_data_dir(ex, data, target, onnx_model)
    for chk in rep.checks:
        v.add(chk.name, _problem(chk), chk.compared, info=f"{chk.rows} rows")
    for o in rep.oracles:
        add_oracle(v, o)


def add_oracle(v: Verdict, o) -> None:
    """An oracle comparison (seagen.reference.oracle.OracleReport) as a check, its label printed once."""
    v.add(o.what, None if o.ok else o.detail(), o.detail() if o.ok else "")


def _problem(chk) -> str | None:
    """The first mismatch of a Check as one line, or None."""
    return None if chk.ok else "; ".join(f"{k} differs at {m}" for k, m in chk.mismatches.items())


def numbers_names(root: Path, man: Manifest, core: str, data: str | None) -> list[str]:
    """The stable names of the checks that follow drift, in order (to mark them skipped)."""
    p = man.prefix
    head = root / f"{p}.h"
    step = head.is_file() and f"{p}_step(" in head.read_text(errors="replace")
    names = [constants_name(p), infer_name(p, core), oracle_name(p)]
    if step and data is None:
        names.append(f"{p}_step on synthetic sequences")
    elif step:
        for split in ("test", "validation"):
            names += [f"{p}_infer on {split} rows", f"{p}_step on {split} trials"]
        names += ["C vs original on test rows", "C vs original on validation rows"]
    if man.data["options"].get("controller"):
        from seagen.verify.tick import tick_name

        names.append(tick_name(p))
    return names


def constants_name(p: str) -> str:
    """The stable name of the header-constants check."""
    return f"{p} header constants (compiled) == the export's"


def infer_name(p: str, core: str) -> str:
    """The stable name of the NAME_infer check on random and edge vectors."""
    return f"{p}_infer on random and edge vectors ({core}): C == numpy == torch == onnxruntime"


def oracle_name(p: str) -> str:
    """The stable name of the oracle check."""
    return f"{p}: integer reference within the proven bound of the original model"


def skip_rest(v: Verdict, names: list[str], why: str) -> Verdict:
    """Mark every check not run yet as skipped, with the reason."""
    done = {i.name for i in v.items}
    for n in names:
        if n not in done:
            v.skip(n, why)
    return v


def build_problem(e: BaseException, root: Path) -> str:
    """A build failure of the C on disk as one line: the first compiler error, its file named in DIR."""
    text = getattr(e, "stderr", None) or str(e)
    for line in text.splitlines():
        m = re.search(r"([\w.+-]+\.[ch]):(\d+):(?:\d+:)? (?:fatal )?error: (.*)", line)
        if m:
            return f"{root / m.group(1)}:{m.group(2)}: does not compile: {m.group(3)}"
    if m := re.search(r"undefined (?:symbol|reference to)[: ]*[`'\"]?(\w+)", text):
        return f"{root}: the C does not build: {m.group(1)} is declared but not defined"
    for line in text.splitlines():
        if "error" in line.lower():
            return f"{root}: the C does not build: {line.strip()}"
    return f"{root}: the C does not build: {text.strip().splitlines()[0] if text.strip() else e}"


def build_errors() -> tuple[type[BaseException], ...]:
    """Exceptions a build of the C on disk raises when the C is broken."""
    import cffi

    errors: list[type[BaseException]] = [UserError, ImportError, cffi.VerificationError]
    try:
        from setuptools.errors import CompileError, LinkError

        errors += [CompileError, LinkError]
    except ImportError:  # pragma: no cover - setuptools ships with cffi's build
        pass
    return tuple(errors)


def verify(
    folder: str,
    model: str,
    prefix: str | None = None,
    data: str | None = None,
    vectors: int = 10_000,
    core: str = "host",
    features: str | None = None,
    allow_pickle: bool = False,
    misra: bool = False,
    actuator=None,
    prove: bool = False,
) -> Verdict:
    """Every check of `seagen verify`, in order: drift first (model, files, manifest, quantization), then
    numbers (header constants, NAME_infer, the oracle, NAME_step, the controller); checks after a failure
    that makes them meaningless are marked skipped (see the README, "Use in CI")."""
    from seagen.codegen.render import model_hash
    from seagen.runtime.features import has_pipeline

    if core not in NAMES:
        raise UserError(f"--target must be one of {', '.join(NAMES)}, not {core!r}")
    if vectors < 0:
        raise UserError(f"--vectors must be >= 0, got {vectors}")
    root, mpath = Path(folder), Path(resolve_model(model))
    man, matches = select(root, mpath, prefix)
    v = Verdict(man.prefix, str(root))
    check_version(v, man)
    check_model(v, man, mpath, matches)
    if misra:
        from seagen.verify.misra import check_folder

        check_folder(v, root, man.data["options"].get("target", "portable"))
    if prove:  # Frama-C Eva over the contracts' domain (docs/prove.md); missing frama-c: exit 2
        from seagen.verify.prove import check_prove

        check_prove(v, root, man)
    changed = changed_files(root, man)
    later = numbers_names(root, man, core, data)
    if not matches or "missing" in changed.values():
        check_files(v, root, man, changed, None)
        check_stray(v, root, man)
        why = "another model" if not matches else "a file of the export is missing"
        return skip_rest(v, [fields_name(man), "quantization unchanged", *later], f"not run: {why}")
    try:
        ex = rebuild(man, mpath, features, allow_pickle, bool(man.data["options"].get("onnx")), actuator)
    except CheckFailed as e:  # the original model and the integer reference disagree beyond the bound
        check_files(v, root, man, changed, None)
        check_stray(v, root, man)
        v.add(oracle_name(man.prefix), str(e))
        why = "not run: the model disagrees with its bound"
        return skip_rest(v, [fields_name(man), "quantization unchanged", *later], why)
    check_files(v, root, man, changed, ex.files)
    check_stray(v, root, man)
    check_fields(v, man, Manifest(man.path, json.loads(ex.files[man.path.name])))
    want, got = man.data["resolved"]["qmodel_hash"], model_hash(ex.qmodel)
    v.add(
        "quantization unchanged",
        None
        if got == want
        else f"this seagen quantizes {mpath.name} to {got}; the export holds {want}: "
        "re-export with seagen export",
        kind="drift",
    )
    if got != want:
        return skip_rest(v, later, "not run: the quantization changed")
    qm, p = ex.qmodel, man.prefix
    files = disk_files(root, man)
    try:
        v.add(constants_name(p), constants_problem(root, files, ex.files, p))
        target = build_target(core, files, p, qm)
    except build_errors() as e:
        v.add(infer_name(p, core), build_problem(e, root))
        return skip_rest(v, later, "not run: the C on disk does not build")
    onnx_model, onnx_what = onnx_ref.build_onnx(qm), ""
    if f"{p}.onnx" in man.files:  # the graph on disk is the one onnxruntime runs
        onnx_model, onnx_what = load_onnx(root / f"{p}.onnx"), f"onnxruntime ran {p}.onnx on disk"
        if onnx_model is None:
            v.add(infer_name(p, core), f"{root / f'{p}.onnx'}: not a readable ONNX graph")
            return skip_rest(v, later, f"not run: {p}.onnx is unreadable")
    if vectors == 0:
        v.warnings.append("--vectors 0: NAME_infer is checked on the edge vectors only")
    edges = edge_inputs(len(qm.inputs))
    x = np.vstack([random_inputs(qm, vectors, seed=0), edges])
    chk = compare("infer", qm, target, x, onnx_model)
    v.add(infer_name(p, core), _problem(chk), onnx_what, info=f"{vectors} random + {len(edges)} edge vectors")
    v.add(oracle_name(p), None, ex.oracle.line())
    if has_pipeline(qm):
        check_steps(v, ex, target, data, onnx_model)
    elif data is not None:
        v.warnings.append(f"{p} has NAME_infer only (no feature pipeline): --data rows not used")
    if man.data["options"].get("controller"):
        from seagen.verify.tick import check_controller, tick_name

        try:
            check_controller(v, files, p, qm, ex.act)
        except build_errors() as e:
            v.add(tick_name(p), build_problem(e, root))
    return v


def load_onnx(path: Path):
    """The export's NAME.onnx as on disk, or None when it does not parse (an edited graph)."""
    import onnx

    try:
        return onnx.load(str(path))
    except Exception:  # any parse failure of an edited graph is reported as a failed check
        return None
