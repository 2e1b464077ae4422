"""flexmb's import graph: no cycles, no upward arrows, the paper studies on top (issue 18).

Read from the source with `ast`: every ``import`` of a flexmb module, at module level or inside a
function (a deferred import is still an arrow), is an edge. ``from pkg import name`` is an edge to
``pkg.name`` when that is a module, else to ``pkg``. Importing ``pkg.sub`` is an edge to
``pkg.sub`` only (the package's ``__init__`` is a facade that re-exports its members; its own
imports are edges of its own).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "flexmb"

# The allowed order, bottom up (written down once, here). A module may import modules of its own
# layer or of a layer below. Package facades (``__init__``) sit with their highest member.
LAYERS = [
    ("foundation", ["flexmb._version", "flexmb._warnings", "flexmb.jit", "flexmb.errors", "flexmb.rotations", "flexmb._validate",
                    "flexmb.units", "flexmb.materials", "flexmb.sections", "flexmb.protocols", "flexmb._timing"]),
    ("elements and joints", ["flexmb.fe", "flexmb.fe.beam2d", "flexmb.fe.beam3d", "flexmb.fe.beam2d_jit",
                             "flexmb.fe.beam3d_jit", "flexmb.fe.beam_step_jit", "flexmb.fe.assembly_jit", "flexmb.fe.assembly", "flexmb.fe.model_jit", "flexmb.fe.model", "flexmb.fe.stress_jit", "flexmb.fe.stress",
                             "flexmb.fe.mass", "flexmb.fe.ideal", "flexmb.fe.section_geometry", "flexmb.closed_form.flexures", "flexmb.closed_form.linkage_jit",
                             "flexmb.joints",
                             "flexmb.joints.*", "flexmb.registry", "flexmb.reference"]),
    ("problems", ["flexmb.linear", "flexmb.linear_jit", "flexmb.problem", "flexmb.closed_form.problem", "flexmb.compiled"]),
    ("builders", ["flexmb.boundary", "flexmb.fe.build", "flexmb.fe.joint_points", "flexmb.closed_form", "flexmb.closed_form.build"]),
    ("mechanism", ["flexmb.mechanism", "flexmb.files"]),
    ("results and joint data", ["flexmb.linearisation", "flexmb.results", "flexmb.database.eob_format", "flexmb.database.store", "flexmb.ksd", "flexmb.ksd.*"]),
    ("strategies and analysis", ["flexmb.plausibility_jit", "flexmb.plausibility", "flexmb.solvers", "flexmb.solvers.*", "flexmb.accuracy", "flexmb.analysis", "flexmb.joint_characteristics", "flexmb.modal",
                                 "flexmb.linearised", "flexmb.statespace", "flexmb.peers", "flexmb.design", "flexmb.design.*", "flexmb.testing_ksd", "flexmb.testing", "flexmb.database", "flexmb.database.training",
                                 "flexmb.models"]),
    ("workflows", ["flexmb.sweeps", "flexmb.study", "flexmb.table", "flexmb.design_properties", "flexmb.path",
                   "flexmb.imperfection",
                   "flexmb.discretisation", "flexmb.design.stroke", "flexmb.design.optimize"]),
    ("faces", ["flexmb.plot", "flexmb.export"]),
    ("studies", ["flexmb.studies", "flexmb.studies.*"]),
    ("command line and package", ["flexmb.cli", "flexmb"]),
]
MAY_IMPORT_STUDIES = {"flexmb.cli"}  # the command line runs the demo and the benchmarks' studies


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def _resolve(module: str, node: ast.ImportFrom) -> str:
    is_package = MODULES[module].name == "__init__.py"
    base = module.split(".")
    if node.level:
        base = base[: len(base) - node.level + (1 if is_package else 0)]
        return ".".join(base + ([node.module] if node.module else []))
    return node.module or ""


def imports(module: str) -> set[str]:
    """The flexmb modules that ``module`` imports (module level and deferred)."""
    out = set()
    for node in ast.walk(ast.parse(MODULES[module].read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.split(".")[0] == "flexmb")
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(module, node)
            if target.split(".")[0] != "flexmb":
                continue
            for alias in node.names:
                out.add(f"{target}.{alias.name}" if f"{target}.{alias.name}" in MODULES else target)
    return {m for m in out if m != module}


def layer(module: str) -> int:
    for k, (_, members) in enumerate(LAYERS):  # a module named exactly wins over a pattern
        if module in members:
            return k
    for k, (_, members) in enumerate(LAYERS):
        for pattern in members:
            if module == pattern or (pattern.endswith(".*") and module.startswith(pattern[:-1])):
                return k
    raise AssertionError(f"module {module} has no layer in tests/test_layout.py: add it to LAYERS")


GRAPH = {m: imports(m) for m in MODULES}


def test_every_module_has_a_layer_and_imports_only_existing_modules():
    for module, targets in GRAPH.items():
        layer(module)
        assert targets <= MODULES.keys(), f"{module} imports unknown flexmb modules {targets - MODULES.keys()}"


def test_no_arrow_runs_up():
    upward = [f"{m} ({LAYERS[layer(m)][0]}) -> {t} ({LAYERS[layer(t)][0]})"
              for m, targets in GRAPH.items() for t in targets if layer(t) > layer(m)]
    assert not upward, "imports that run up the layers:\n" + "\n".join(upward)


def test_no_import_cycle():
    # Tarjan's strongly connected components on the static graph
    index, low, stack, on_stack, cycles, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(GRAPH[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


def test_the_library_does_not_import_the_studies():
    offenders = [f"{m} -> {t}" for m, targets in GRAPH.items() for t in targets
                 if t.startswith("flexmb.studies") and not m.startswith("flexmb.studies") and m not in MAY_IMPORT_STUDIES]
    assert not offenders, offenders


def test_import_flexmb_loads_no_study():
    # issue 18: `python -c "import flexmb, sys; print([m for m in sys.modules if m.startswith('flexmb.studies')])"`
    code = "import flexmb, sys; print([m for m in sys.modules if m.startswith('flexmb.studies')])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=ROOT.parent).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize("mutant, expected", [
    ({"flexmb.rotations": {"flexmb.mechanism"}}, "run up"),
    ({"flexmb.mechanism": {"flexmb.studies.demo"}}, "studies"),
])
def test_the_checks_reject_a_mutant_graph(monkeypatch, mutant, expected):
    graph = {m: set(t) for m, t in GRAPH.items()}
    for m, extra in mutant.items():
        graph[m] |= extra
    monkeypatch.setattr(sys.modules[__name__], "GRAPH", graph)
    check = test_no_arrow_runs_up if expected == "run up" else test_the_library_does_not_import_the_studies
    with pytest.raises(AssertionError):
        check()


def test_the_cycle_check_rejects_a_cycle(monkeypatch):
    graph = {m: set(t) for m, t in GRAPH.items()}
    graph["flexmb.sections"] |= {"flexmb._validate"}
    graph["flexmb._validate"] |= {"flexmb.sections"}  # the cycle issue 18 removed
    monkeypatch.setattr(sys.modules[__name__], "GRAPH", graph)
    with pytest.raises(AssertionError, match="cycles"):
        test_no_import_cycle()
