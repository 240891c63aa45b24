"""swarm_sim's layout: folders in layers that never import upwards, faces that offer their own folder's names,
and other packages that import faces (or a command's module), not the modules behind them."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "swarm_sim"
SRC = PACKAGE.parent.parent
LAYERS = (
    ("errors",),
    ("model",),
    ("tasks", "core"),
    ("roads",),
    ("evaluation",),
    ("validation", "bench", "nodes"),
)
LAYER = {folder: depth for depth, folders in enumerate(LAYERS) for folder in folders}
FACES = ("model", "tasks", "core", "roads", "evaluation", "validation")
COMMAND_MODULES = {"swarm_sim.evaluation.cli", "swarm_sim.validation.cli", "swarm_sim.tasks.cli"}


def _imports(path: Path) -> list[str]:
    """The swarm_sim modules a file imports (``from swarm_sim.X import ...`` and ``import swarm_sim.X``)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "swarm_sim":
                found += [f"swarm_sim.{alias.name}" for alias in node.names]
            elif node.module.startswith("swarm_sim."):
                found.append(node.module)
        elif isinstance(node, ast.Import):
            found += [alias.name for alias in node.names if alias.name.startswith("swarm_sim.")]
    return found


def _folder(path: Path) -> str:
    parts = path.relative_to(PACKAGE).parts
    return parts[0] if len(parts) > 1 else Path(parts[0]).stem


def test_every_module_sits_in_a_known_layer():
    folders = {_folder(path) for path in PACKAGE.rglob("*.py")} - {"__init__"}
    assert folders == set(LAYER), (
        "a folder of swarm_sim is missing from LAYERS, or LAYERS names one that is gone"
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
    module = importlib.import_module(f"swarm_sim.{face}")
    assert module.__all__, f"swarm_sim.{face} offers nothing"
    for name in module.__all__:
        value = getattr(module, name)
        origin = getattr(value, "__module__", None)
        if origin is not None and not isinstance(value, (str, int, float, tuple, dict, frozenset)):
            assert origin.startswith(f"swarm_sim.{face}"), f"swarm_sim.{face}.{name} comes from {origin}"


OTHER_PACKAGES = [
    path
    for package in ("bt_controller", "evolution_manager", "swarm_ros")
    for path in sorted((SRC / package / package).rglob("*.py"))
] + sorted((PACKAGE / "nodes").rglob("*.py"))


@pytest.mark.parametrize("path", OTHER_PACKAGES, ids=lambda p: str(p.relative_to(SRC)))
def test_code_outside_swarm_sim_imports_faces_or_commands(path):
    for module in _imports(path):
        parts = module.split(".")
        if len(parts) > 2 and parts[1] in FACES and module not in COMMAND_MODULES:
            pytest.fail(f"{path.relative_to(SRC)} imports {module}: import from swarm_sim.{parts[1]} instead")
