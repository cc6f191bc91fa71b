"""The framework's folder is its architecture: layers import only downwards, nothing imports in a
circle, and ``cosim`` never imports the physics.

Every import counts, also one inside a function (the graph below is read from the source, not from
what happens to be imported at run time). Layers, lowest first::

    contract   timebase errors messages params component registry jit_time docsection examples
    codec      cosim.codec.*                     (a message's exact wire form)
    scene      scenario scheduler                (scene loading, the master algorithm)
    record     cosim.record.*                    (recorder observer, writer process, reader)
    view       cosim.view.*                      (viewer items, Foxglove, live)
    run        runner replay progress cli        (a run end to end, the command line)
    sweep      cosim.sweep.*                     (many runs of one scene)
    fmi        cosim.fmi.*                       (scenes exported as FMUs, FMUs built from models)
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

COSIM = Path(__file__).resolve().parents[1] / "cosim"

LAYERS = {
    "contract": ["cosim", "cosim.timebase", "cosim.errors", "cosim.messages", "cosim.params",
                 "cosim.component", "cosim.registry", "cosim.jit_time", "cosim.docsection",
                 "cosim.examples"],
    "codec": ["cosim.codec"],
    "scene": ["cosim.scenario", "cosim.scheduler"],
    "record": ["cosim.record"],
    "view": ["cosim.view"],
    "run": ["cosim.runner", "cosim.replay", "cosim.progress", "cosim.cli"],
    "sweep": ["cosim.sweep"],
    "fmi": ["cosim.fmi"],
}
ORDER = list(LAYERS)


def module_name(path: Path) -> str:
    parts = path.relative_to(COSIM.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(COSIM.rglob("*.py"))}


def layer_of(module: str) -> str:
    """The layer of a module: the one naming it or the package holding it."""
    for layer, members in LAYERS.items():
        if any(module == m or module.startswith(m + ".") for m in members if m != "cosim") or module in members:
            return layer
    raise AssertionError(f"{module} is in no layer: add it to LAYERS (and to docs/architecture.md)")


def imports_of(module: str) -> set[str]:
    """Every module ``module`` imports (anywhere in its source, except under TYPE_CHECKING)."""
    tree = ast.parse(MODULES[module].read_text())
    typing_only: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            typing_only.update(id(n) for n in ast.walk(node))
    found: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            # "from package import submodule" imports the submodule too
            found.update(f"{node.module}.{a.name}" for a in node.names if f"{node.module}.{a.name}" in MODULES)
    return found


GRAPH = {m: {i for i in imports_of(m) if i in MODULES and i != m} for m in MODULES}


def test_the_top_of_cosim_holds_at_most_16_modules_and_at_least_three_subpackages():
    top = sorted(p.name for p in COSIM.glob("*.py"))
    packages = sorted(p.name for p in COSIM.iterdir() if (p / "__init__.py").exists())
    assert len(top) <= 16, top
    assert len(packages) >= 3, packages


def test_no_two_files_share_a_prefix_standing_in_for_a_package():
    for folder in [COSIM, *(p for p in COSIM.iterdir() if p.is_dir() and (p / "__init__.py").exists())]:
        stems = [p.stem for p in folder.glob("*.py") if p.stem != "__init__"]
        prefixes = [s.split("_")[0] for s in stems if "_" in s]
        shared = {p for p in prefixes if prefixes.count(p) > 1 or p in stems}
        assert not shared, f"{folder.name}/: files named {sorted(shared)}_* should be a package"


def test_every_module_is_in_a_layer():
    for module in MODULES:
        layer_of(module)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_a_module_imports_only_its_own_layer_or_lower_ones(module):
    mine = ORDER.index(layer_of(module))
    higher = sorted(i for i in GRAPH[module] if ORDER.index(layer_of(i)) > mine)
    assert not higher, f"{module} ({layer_of(module)}) imports higher layers: {higher}"


def test_cosim_never_imports_the_physics():
    for module in MODULES:
        physics = sorted(i for i in imports_of(module) if i == "components" or i.startswith("components."))
        assert not physics, f"{module} imports {physics}"


def test_the_scheduler_knows_recording_only_through_the_observer_interface():
    reached = GRAPH["cosim.scheduler"]
    assert not {m for m in reached if layer_of(m) in ("record", "view", "run", "sweep")}


def test_no_import_circle_anywhere_in_cosim():
    """Depth-first search for a back edge; the package ``cosim`` itself (lazy names only) is left out
    since every module imports it implicitly."""
    graph = {m: GRAPH[m] - {"cosim"} for m in MODULES if m != "cosim"}
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        path.append(m)
        for n in sorted(graph.get(m, ())):
            if state.get(n) == 1:
                raise AssertionError("import circle: " + " -> ".join([*path[path.index(n):], n]))
            if n not in state:
                visit(n)
        path.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)


def test_the_checker_finds_a_circle_and_a_higher_import(tmp_path, monkeypatch):
    """The graph really is read from the source: an import inside a function is seen."""
    text = MODULES["cosim.scheduler"].read_text() + "\n\ndef _probe():\n    from cosim.runner import run_scene\n"
    source = tmp_path / "scheduler.py"
    source.write_text(text)
    monkeypatch.setitem(MODULES, "cosim.scheduler", source)
    assert "cosim.runner" in imports_of("cosim.scheduler")
