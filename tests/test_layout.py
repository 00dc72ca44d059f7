"""The package's layout is its pipeline: one folder a stage, imports from a stage to an
earlier one only (deferred imports inside functions included), no import cycle between
modules, at most 13 entries at the top of ``dmoc/`` and modules of at most 300 lines
(STYLE.md, "The architecture visible in the tree"). The imports are read from the source
with `ast`, not by importing."""

import ast
import pathlib

import pytest

import dmoc

ROOT = pathlib.Path(dmoc.__file__).parent

# Stage of each top-level entry: a module may import from its own stage or an earlier one.
# simulation and optimal_control are the two consumers of the step residual: they share a
# rank and never import each other. results (diagnostics, plots) reads what they return; the
# drivers (the judged optimize, its accuracy, the MPC) run a consumer and judge its output
# with the diagnostics of results.
STAGES = {"errors": 0, "_util": 1, "mechanics": 2, "discrete": 3, "principle": 4,
          "simulation": 5, "optimal_control": 5, "results": 6, "drivers": 7, "batch": 8, "cli": 9,
          "__main__": 10, "__init__": 10}


def module_name(path):
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def imported_modules(name, path):
    """Every dmoc module `name` imports, at module level or inside functions: for
    ``from X import y`` the module X.y when it is one, else X."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == "dmoc")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            elif (node.module or "").split(".")[0] == "dmoc":
                target = node.module
            else:
                continue
            for alias in node.names:
                found.add(f"{target}.{alias.name}" if f"{target}.{alias.name}" in MODULES else target)
    return found - {name}


GRAPH = {name: imported_modules(name, path) for name, path in MODULES.items()}


def stage(name):
    parts = name.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


def test_the_graph_is_read():
    """The reader finds the imports it must (a test of the test)."""
    assert "dmoc.principle.residual" in GRAPH["dmoc.simulation.preparation"]
    assert "dmoc._util.checks" in GRAPH["dmoc.optimal_control.solver.solving"]
    assert "dmoc.discrete" in GRAPH["dmoc.principle.residual"]
    assert set(STAGES) >= {stage(name) for name in MODULES}


@pytest.mark.parametrize("name", sorted(MODULES))
def test_imports_run_to_earlier_stages(name):
    own = stage(name)
    later = sorted(target for target in GRAPH[name]
                   if STAGES[stage(target)] > STAGES[own]
                   or (STAGES[stage(target)] == STAGES[own] and stage(target) != own))
    assert not later, f"{name} (stage {own}) imports from a later or sibling stage: {later}"


def test_no_import_cycle():
    """Depth-first search over module imports; a back edge is a cycle."""
    state, path = {}, []

    def visit(name):
        state[name] = "open"
        path.append(name)
        for target in sorted(GRAPH[name]):
            if state.get(target) == "open":
                raise AssertionError("import cycle: " + " -> ".join(path[path.index(target):] + [target]))
            if target not in state:
                visit(target)
        path.pop()
        state[name] = "done"

    for name in sorted(GRAPH):
        if name not in state:
            visit(name)


@pytest.mark.parametrize("name", sorted(MODULES))
def test_modules_have_at_most_300_lines(name):
    """STYLE.md: modules of at most ~300 lines, split when one gets a second job."""
    lines = len(MODULES[name].read_text().splitlines())
    assert lines <= 300, f"{name} has {lines} lines; split it by job"


def test_at_most_thirteen_entries_at_the_top():
    """Nine stages (the drivers the ninth, issue 39), errors, _util, __init__ and __main__."""
    entries = sorted(p.name for p in ROOT.iterdir() if p.name != "__pycache__")
    assert len(entries) <= 13, entries
