"""seagen's packages import in one direction: downward through the layers of LAYERS, with no cycle."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import seagen

ROOT = Path(seagen.__file__).resolve().parent


def node_of(module: str) -> str | None:
    """The graph node of a dotted module name: seagen.X for anything under seagen.X (None outside)."""
    parts = module.split(".")
    return parts[1] if parts[0] == "seagen" and len(parts) > 1 else None


def module_name(path: Path) -> str:
    """Dotted name of a source file under seagen/."""
    rel = path.relative_to(ROOT.parent).with_suffix("")
    return ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)


def imports_of(path: Path) -> set[str]:
    """Every module a file imports, at any depth (function-local imports count too)."""
    tree = ast.parse(path.read_text(), str(path))
    out: set[str] = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            out.update(a.name for a in n.names)
        elif isinstance(n, ast.ImportFrom):
            assert not n.level, f"{path}: relative import (seagen uses absolute imports)"
            base = n.module or ""
            out.add(base)
            out.update(f"{base}.{a.name}" for a in n.names)
    return out


def package_graph() -> dict[str, dict[str, str]]:
    """node -> {imported node: one file that imports it}."""
    graph: dict[str, dict[str, str]] = defaultdict(dict)
    for path in sorted(ROOT.rglob("*.py")):
        src = node_of(module_name(path))
        for mod in imports_of(path):
            dst = node_of(mod)
            if src and dst and dst != src:
                graph[src].setdefault(dst, str(path.relative_to(ROOT.parent)))
    return graph


def find_cycle(graph: dict[str, dict[str, str]]) -> list[str]:
    """One cycle of the graph as a node list (first node repeated at the end), or []."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str]:
        state[n] = 1
        stack.append(n)
        for m in sorted(graph.get(n, {})):
            if state.get(m) == 1:
                return stack[stack.index(m) :] + [m]
            if m not in state and (c := visit(m)):
                return c
        stack.pop()
        state[n] = 2
        return []

    for n in sorted(graph):
        if n not in state and (c := visit(n)):
            return c
    return []


# The layers, bottom-up (README "How it is built"). BOTTOM is shared by both sides; the physics side (the
# simulated actuator and what is fitted to it) and the compiler side (model -> C) never import each other;
# the drivers on top join them. A package imports only packages listed before it in its own list or in a
# list below it (BOTTOM for a side; BOTTOM and both sides for the drivers).
BOTTOM = [
    "__version__",
    "errors",
    "c_runtime",
    "actuators",
    "atomic",
    "workers",
    "filekind",
    "fields",
    "cnames",
    "fmath",
    "actuator",
    "geometry",
    "ir",
    "plotting",
    "modelfile",
    "defaults",
    "runtime",
]
PHYSICS = ["plant", "data", "fit", "discrepancy"]
COMPILER = ["quant", "frontends", "reference", "codegen", "toolchain", "pil"]
DRIVERS = ["control", "setups", "datacheck", "export", "verify", "bench", "testing", "demo", "cli"]
# The closed loop and the experiment run what `setups` builds from model files (a predictor, its C, a board's
# firmware): of the compiler side, control imports only the integer references and the toolchain.
RUNS_ONLY = {"control": {"reference", "toolchain"}}


def allowed(src: str) -> set[str]:
    """The packages `src` may import."""
    for i, layer in enumerate((BOTTOM, PHYSICS, COMPILER, DRIVERS)):
        if src in layer:
            below = set(layer[: layer.index(src)]) | set(BOTTOM)
            return below | (set(PHYSICS) | RUNS_ONLY.get(src, set(COMPILER)) if i == 3 else set())
    raise AssertionError(f"package '{src}' is in no layer of tests/test_structure.py: place it")


def violations(graph: dict[str, dict[str, str]]) -> list[str]:
    """Every import of a package not below the importer, as 'src -> dst (file)'."""
    return [
        f"{src} -> {dst} ({where})"
        for src, dsts in sorted(graph.items())
        for dst, where in sorted(dsts.items())
        if dst not in allowed(src)
    ]


def test_packages_import_only_lower_layers():
    """Every package (function-level imports included) imports only packages below it in LAYERS."""
    graph = package_graph()
    for name in {n for n in graph} | {d for ds in graph.values() for d in ds}:
        allowed(name)  # every package is placed
    assert not violations(graph), "imports from a higher layer or across sides: " + "; ".join(
        violations(graph)
    )


def test_layer_checker_finds_planted_violations():
    """The checker itself: an import across the sides, an upward import, a driver import and the closed
    loop building (reading a model file, rendering C) are found."""
    planted = {
        "plant": {"codegen": "seagen/plant/x.py", "geometry": "seagen/plant/sim.py"},
        "quant": {"reference": "seagen/quant/y.py"},
        "toolchain": {"export": "seagen/toolchain/z.py"},
        "cli": {"plant": "seagen/cli/data.py"},
        "control": {"frontends": "seagen/control/a.py", "codegen": "seagen/control/b.py", "toolchain": ""},
    }
    assert violations(planted) == [
        "control -> codegen (seagen/control/b.py)",
        "control -> frontends (seagen/control/a.py)",
        "plant -> codegen (seagen/plant/x.py)",
        "quant -> reference (seagen/quant/y.py)",
        "toolchain -> export (seagen/toolchain/z.py)",
    ]


def test_package_imports_form_a_dag():
    """No cycle between seagen's packages (each top-level module counts as its own node)."""
    graph = package_graph()
    cycle = find_cycle(graph)
    where = [f"{a} -> {b} ({graph[a][b]})" for a, b in zip(cycle, cycle[1:], strict=False)]
    assert not cycle, "package import cycle: " + "; ".join(where)


def test_cycle_finder_finds_a_planted_cycle():
    """The checker itself: a planted a -> b -> c -> a cycle is found, a DAG gives none."""
    assert find_cycle({"a": {"b": ""}, "b": {"c": ""}, "c": {"a": ""}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b": ""}, "b": {"c": ""}, "c": {}}) == []


def test_library_modules_do_not_import_the_demo():
    """Only the CLI imports the demo."""
    drivers = {"cli", "demo"}
    bad = [
        f"{src} ({dst_file})"
        for src, dsts in package_graph().items()
        for dst, dst_file in dsts.items()
        if dst == "demo" and src not in drivers
    ]
    assert not bad, "library modules import the demo: " + ", ".join(bad)


def test_integer_reference_loads_no_plant_or_torch():
    """Importing the numpy integer reference and the primitives loads neither the plant nor torch."""
    import subprocess
    import sys

    probe = (
        "import sys, seagen.reference.numpy_ref, seagen.runtime.fixed, seagen.runtime.nn;"
        "print(sorted(m for m in sys.modules if m.startswith(('seagen.plant', 'seagen.data', 'torch'))))"
    )
    res = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert res.stdout.strip() == "[]", res.stdout


def test_unpickling_only_behind_the_opt_in():
    """`weights_only=False` appears once, in modelfile.safe_load, inside its `if allow_pickle:` branch;
    every allow_pickle parameter in seagen defaults to False (the CLI flags are store_true: off unless
    given)."""
    unsafe, guarded, defaults = [], [], []
    for path in sorted(ROOT.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        for fn in (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)):
            args = fn.args.args + fn.args.kwonlyargs
            vals = [None] * (len(fn.args.args) - len(fn.args.defaults)) + list(fn.args.defaults)
            vals += list(fn.args.kw_defaults)
            for a, d in zip(args, vals, strict=True):
                if a.arg == "allow_pickle" and not (isinstance(d, ast.Constant) and d.value is False):
                    defaults.append(f"{path.name}:{fn.name}")
            opt_in = [
                c
                for i in ast.walk(fn)
                if isinstance(i, ast.If) and isinstance(i.test, ast.Name) and i.test.id == "allow_pickle"
                for b in i.body
                for c in ast.walk(b)
            ]
            for call in (c for c in ast.walk(fn) if isinstance(c, ast.Call)):
                for kw in call.keywords:
                    if kw.arg == "weights_only" and not (
                        isinstance(kw.value, ast.Constant) and kw.value.value
                    ):
                        where = f"{path.name}:{fn.name}"
                        (guarded if any(call is c for c in opt_in) else unsafe).append(where)
    assert guarded == ["modelfile.py:safe_load"] and not unsafe, (guarded, unsafe)
    assert not defaults, f"allow_pickle without a False default: {defaults}"


def test_torch_archive_readers_only_behind_the_opt_in_or_the_check():
    """`torch.export.load` is called only inside an `if allow_pickle:` branch (without it a .pt2 is rebuilt
    from its checked JSON and raw tensors); `torch.jit.load` only there or after `check_torchscript` in the
    same function."""
    found: list[tuple[str, str, bool]] = []
    for path in sorted(ROOT.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        for fn in (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)):
            opt_in = {
                id(c)
                for i in ast.walk(fn)
                if isinstance(i, ast.If) and isinstance(i.test, ast.Name) and i.test.id == "allow_pickle"
                for b in i.body
                for c in ast.walk(b)
            }
            checked = [
                c.lineno
                for c in ast.walk(fn)
                if isinstance(c, ast.Call)
                and isinstance(c.func, ast.Name)
                and c.func.id == "check_torchscript"
            ]
            for call in (c for c in ast.walk(fn) if isinstance(c, ast.Call)):
                name = ast.unparse(call.func)
                if name.endswith(("export.load", "jit.load")):
                    ok = id(call) in opt_in or (
                        name.endswith("jit.load") and any(line < call.lineno for line in checked)
                    )
                    found.append((f"{path.name}:{fn.name}", name, ok))
    assert {n for _w, n, _ok in found} == {"torch.export.load", "torch.jit.load"}, found
    assert all(ok for _w, _n, ok in found), found


def test_allow_pickle_flags_are_opt_in():
    """Every `--allow-pickle` the commands define is a store_true flag (False unless the user types it), so
    the one unpickling branch (`if allow_pickle:` in modelfile.safe_load) is reached only on that opt-in."""
    flags = []
    for path in sorted(ROOT.rglob("*.py")):
        for call in (n for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.Call)):
            if any(isinstance(a, ast.Constant) and a.value == "--allow-pickle" for a in call.args):
                action = next((k.value for k in call.keywords if k.arg == "action"), None)
                default = next((k.value for k in call.keywords if k.arg == "default"), None)
                ok = isinstance(action, ast.Constant) and action.value == "store_true" and default is None
                flags.append((path.name, ok))
    assert len(flags) >= 5 and all(ok for _, ok in flags), flags
