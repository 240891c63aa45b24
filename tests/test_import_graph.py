"""The workspace's Python modules import each other without a cycle, counting imports inside functions.

A cycle hidden by an import inside a function still ties two modules together: neither can be read, tested
or moved alone. Each module is a node; ``from a.b import c`` is an edge to ``a.b.c`` when that is a module,
else to ``a.b``. A package's ``__init__`` importing its own modules is no cycle (Python loads the package
first), so edges from a module to the package that holds it are left out.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"
PACKAGES = ("bt_controller", "swarm_sim", "evolution_manager", "swarm_ros")


def _modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        root = SRC / package
        for path in (root / package).rglob("*.py"):
            parts = path.relative_to(root).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def import_graph() -> dict[str, set[str]]:
    """Every module of the workspace and the workspace modules it imports anywhere in its text."""
    modules = _modules()

    def resolve(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        targets: set[str | None] = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                targets |= {resolve(f"{node.module}.{alias.name}") for alias in node.names}
            elif isinstance(node, ast.Import):
                targets |= {resolve(alias.name) for alias in node.names}
        graph[name] = {t for t in targets if t and t != name and not name.startswith(f"{t}.")}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_finder_finds_a_cycle_through_an_import_inside_a_function():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_the_graph_sees_imports_inside_functions():
    graph = import_graph()
    # the experiment command imports the foraging study only inside the function that plans one
    assert "evolution_manager.studies.foraging_study" in graph["evolution_manager.studies.experiment"]
    assert "evolution_manager.viewing.explorer" in graph["evolution_manager.viewing.results"]
    assert len(graph) > 100


def test_no_module_of_the_workspace_is_in_an_import_cycle():
    assert cycles(import_graph()) == []


def late_imports_without_a_reason(path: Path) -> list[int]:
    """The lines of ``path``'s imports inside functions that give no reason: an import is deliberate late
    load only with a comment on its own lines, on the line above it, or on the first of the run of late
    imports it belongs to (a block of them shares one comment)."""
    lines = path.read_text().splitlines()
    spans = sorted(
        {
            (node.lineno, node.end_lineno or node.lineno)
            for function in ast.walk(ast.parse("\n".join(lines)))
            if isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef))
            for node in ast.walk(function)
            if isinstance(node, (ast.Import, ast.ImportFrom))
        }
    )
    ends = {end: start for start, end in spans}
    unexplained = []
    for start, end in spans:
        first = start
        while first - 1 in ends:  # the run of late imports this one closes
            first = ends[first - 1]
        said = lines[first - 2 : first - 1] + lines[first - 1 : end]
        if not any("#" in line for line in said):
            unexplained.append(start)
    return unexplained


def test_the_reason_finder_reads_a_block_of_late_imports_as_one(tmp_path):
    module = tmp_path / "late.py"
    module.write_text(
        "def a():\n"
        "    # late: loads a library\n"
        "    import json\n"
        "    import os\n"
        "\n"
        "def b():\n"
        "    x = 1\n"
        "    import re\n"
        "    import sys  # late: a reason\n"
    )
    assert late_imports_without_a_reason(module) == [8]


def test_every_import_inside_a_function_says_why_it_is_late():
    unexplained = [
        f"{path.relative_to(SRC)}:{line}"
        for path in sorted(_modules().values())
        for line in late_imports_without_a_reason(path)
    ]
    assert unexplained == []
