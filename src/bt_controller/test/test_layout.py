"""bt_controller's layout: folders in layers that never import upwards, faces that offer their own folder's
names, a light ``bt_controller`` (no numba on import), and other packages that import faces (or a command's
module), not the modules behind them."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "bt_controller"
SRC = PACKAGE.parent.parent
LAYERS = (
    ("errors", "validate", "lean_numba", "model_settings"),
    ("draws", "language"),
    ("interpreters",),
    ("robot",),
    ("tools", "bench", "nodes"),
)
LAYER = {folder: depth for depth, folders in enumerate(LAYERS) for folder in folders}
FACES = ("language", "interpreters", "robot", "tools")
COMMAND_MODULES = {
    "bt_controller.tools.cli",
    "bt_controller.bench.tick_bench",
    "bt_controller.bench.simplify_measure",
    "bt_controller.nodes.footbot_controller",
}


def _imports(path: Path) -> list[str]:
    """The bt_controller modules a file imports (``from bt_controller.X import ...``,
    ``import bt_controller.X`` and ``from bt_controller import X``), wherever the import stands."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "bt_controller":
                found += [f"bt_controller.{alias.name}" for alias in node.names if alias.name in LAYER]
            elif node.module.startswith("bt_controller."):
                found.append(node.module)
        elif isinstance(node, ast.Import):
            found += [alias.name for alias in node.names if alias.name.startswith("bt_controller.")]
    return found


def _folder(path: Path) -> str:
    parts = path.relative_to(PACKAGE).parts
    return parts[0] if len(parts) > 1 else Path(parts[0]).stem


def test_every_module_sits_in_a_known_layer():
    folders = {_folder(path) for path in PACKAGE.rglob("*.py")} - {"__init__"}
    assert folders == set(LAYER), (
        "a folder or root module of bt_controller is missing from LAYERS, or LAYERS names one that is gone"
    )


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_a_folder_never_imports_a_folder_above_it(path):
    here = _folder(path)
    if here == "__init__":
        return
    for module in _imports(path):
        there = module.split(".")[1]
        assert LAYER[there] <= LAYER[here], f"{path.name} ({here}) imports {module}, a layer above it"
        if LAYER[there] == LAYER[here]:
            assert there == here, f"{path.name} ({here}) imports {module}, a folder of its own layer"


@pytest.mark.parametrize("face", FACES)
def test_a_face_offers_only_names_its_own_folder_defines(face):
    module = importlib.import_module(f"bt_controller.{face}")
    assert module.__all__, f"bt_controller.{face} offers nothing"
    assert len(set(module.__all__)) == len(module.__all__), f"bt_controller.{face} offers a name twice"
    for name in module.__all__:
        value = getattr(module, name)
        origin = getattr(value, "__module__", None)
        if hasattr(value, "py_func"):
            # a numba function may be compiled in this folder from a plain function of a lower layer
            homes = [
                m
                for m in sys.modules
                if m.startswith(f"bt_controller.{face}.") and vars(sys.modules[m]).get(name) is value
            ]
            origin = homes[0] if homes else origin
        if origin is not None and not isinstance(value, (str, int, float, tuple, dict, frozenset)):
            assert origin.startswith(f"bt_controller.{face}."), f"{face}.{name} comes from {origin}"


def test_the_package_face_and_the_language_load_no_numba():
    # A fresh interpreter: this one has long since loaded numba through other tests.
    code = (
        "import sys, bt_controller, bt_controller.language, bt_controller.model_settings\n"
        "print(sorted(m for m in ('numba', 'matplotlib', 'py_trees') if m in sys.modules))"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "[]", f"importing bt_controller's light face loaded {loaded.strip()}"


OTHER_PACKAGES = [
    path
    for package in ("swarm_sim", "evolution_manager", "swarm_ros")
    for path in sorted((SRC / package / package).rglob("*.py"))
] + sorted((PACKAGE / "nodes").rglob("*.py"))


@pytest.mark.parametrize("path", OTHER_PACKAGES, ids=lambda p: str(p.relative_to(SRC)))
def test_code_outside_bt_controller_imports_faces_or_commands(path):
    for module in _imports(path):
        parts = module.split(".")
        if len(parts) > 2 and parts[1] in (*FACES, "bench", "nodes") and module not in COMMAND_MODULES:
            where = path.relative_to(SRC)
            pytest.fail(f"{where} imports {module}: import from bt_controller.{parts[1]} instead")
