"""Build the C on disk as it is; compare it bit for bit with MODEL's references rebuilt from the manifest."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from seagen.build.equivalence import check_data_dir, compare, edge_inputs, random_inputs, step_problem
from seagen.build.targets import NAMES, build_target
from seagen.codegen.manifest import Manifest
from seagen.errors import CheckFailed, UserError
from seagen.reference import onnx_ref
from seagen.verify.drift import check_drift, select
from seagen.verify.result import Verdict


def rebuild(man: Manifest, model: Path, features: str | None, allow_pickle: bool = False):
    """The export MODEL gives today with the manifest's resolved options (ranges, features, weights)."""
    from seagen.export import prepare

    opts, res = man.data["options"], man.data["resolved"]
    return prepare(
        str(model),
        man.prefix,
        opts["weights"],
        None,
        features if features is not None else (res.get("features") or {}),
        False,
        allow_pickle,
        controller=bool(opts.get("controller")),
        target=opts.get("target", "portable"),
        ranges=[[float(lo), float(hi)] for _n, _u, lo, hi in res["inputs"]],
    )


def disk_files(folder: Path, man: Manifest) -> dict[str, str]:
    """The export's C sources and headers as they are on disk (read once, for every check)."""
    return {n: (folder / n).read_text() for n in man.files if n.endswith((".c", ".h"))}


def synthetic_trials(qm, n_trials: int = 4, n: int = 400, seed: int = 0):
    """enc, pot, trial ids: bounded random walks inside the calibrated pot/enc ranges (or the sensors')."""
    rng = np.random.default_rng(seed)
    rng_of = {i.signal.name: (i.signal.lo, i.signal.hi) for i in qm.inputs}
    plo, phi = rng_of.get("pot", (0.0, 4095.0))
    elo, ehi = rng_of.get("enc", (-100.0, 2700.0))
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
    from seagen.quant.features import external_inputs

    qm, p = ex.qmodel, ex.prefix
    ext_names = external_inputs(qm)
    if data is None:
        enc, pot, trial = synthetic_trials(qm)
        rng = np.random.default_rng(1)
        ext = np.column_stack(
            [rng.integers(qi.lo_q, qi.hi_q + 1, len(enc)) for qi in qm.inputs if qi.signal.name in ext_names]
            or [np.zeros((len(enc), 0), dtype=np.int64)]
        )
        v.add(
            f"{p}_step on {len(set(trial))} synthetic sequences",
            step_problem(qm, target, enc, pot, trial, ext),
        )
        return
    rep = check_data_dir(ex, data, target, onnx_model)
    for chk in rep.checks:
        v.add(f"{chk.name} ({chk.rows} rows): {chk.compared}", _problem(chk))
    for o in rep.oracles:
        v.add(o.what, None if o.ok else o.line(), o.line() if o.ok else "")


def _problem(chk) -> str | None:
    """The first mismatch of a Check as one line, or None."""
    return None if chk.ok else "; ".join(f"{k} differs at {m}" for k, m in chk.mismatches.items())


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
) -> Verdict:
    """Every check of `seagen verify`, in order: drift first, then numbers (see the README, "Use in CI")."""
    from seagen.codegen.render import model_hash
    from seagen.quant.features import has_pipeline

    if core not in NAMES:
        raise UserError(f"--core must be one of {', '.join(NAMES)}, not {core!r}")
    if vectors < 0:
        raise UserError(f"--vectors must be >= 0, got {vectors}")
    root, mpath = Path(folder), Path(model)
    man, matches = select(root, mpath, prefix)
    v = Verdict(man.prefix, str(root))
    check_drift(v, root, man, mpath, matches)
    if misra:
        from seagen.verify.misra import check_folder

        check_folder(v, root, man.data["options"].get("target", "portable"))

    if not matches or any(not (root / n).is_file() for n in man.files):
        return v  # numbers against another model, or without every file, say nothing more
    try:
        ex = rebuild(man, mpath, features, allow_pickle)
    except CheckFailed as e:  # the original model and the integer reference disagree beyond the bound
        v.add("integer reference within the proven bound of the original model", str(e))
        return v
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
        return v
    qm = ex.qmodel
    files = disk_files(root, man)
    target = build_target(core, files, man.prefix, qm)
    onnx_model = onnx_ref.build_onnx(qm)  # one graph for every comparison
    if vectors == 0:
        v.warnings.append("--vectors 0: NAME_infer is checked on the edge vectors only")
    edges = edge_inputs(len(qm.inputs))
    x = np.vstack([random_inputs(qm, vectors, seed=0), edges])
    chk = compare("infer", qm, target, x, onnx_model)
    v.add(
        f"{man.prefix}_infer on {vectors} random + {len(edges)} edge vectors ({core}): "
        "C == numpy == torch == onnxruntime",
        _problem(chk),
    )
    v.add(
        f"{man.prefix}: integer reference within the proven bound of the original model",
        None,
        ex.oracle.line(),
    )
    if has_pipeline(qm):
        check_steps(v, ex, target, data, onnx_model)
    elif data is not None:
        v.warnings.append(f"{man.prefix} has NAME_infer only (no feature pipeline): --data rows not used")
    if man.data["options"].get("controller"):
        from seagen.verify.tick import check_controller

        check_controller(v, files, man.prefix, qm)
    return v
