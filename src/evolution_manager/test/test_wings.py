"""The package's wings keep their order: a wing imports only the base modules, itself and the wings below it,
and another wing only through the modules that wing names in ``__all__``; the ROS-free wings load no rclpy."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import evolution_manager

PACKAGE = Path(__file__).resolve().parents[1] / "evolution_manager"  # the sources, not the installed copy
WINGS = evolution_manager.WINGS
ROS_FREE = tuple(wing for wing in WINGS if wing != "graph")  # graph: the one wing that imports rclpy


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _wing(module: str) -> str | None:
    """The wing of a module of the package, or None for a base module (``errors``, ``files`` ...)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 2 or (len(parts) == 2 and parts[1] in WINGS) else None


def _imported(tree: ast.AST, package: str) -> list[tuple[int, str]]:
    """(line, module) of every import of the package, at the top of the file or inside a function; for
    ``from package.wing import name`` the module is ``package.wing.name``."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == package]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] != package:
                continue
            if node.module.count(".") == 1 and node.module.split(".")[1] in WINGS:
                found += [(node.lineno, f"{node.module}.{a.name}") for a in node.names]
            else:
                found.append((node.lineno, node.module))
        elif isinstance(node, ast.ImportFrom) and node.level > 0:
            found.append((node.lineno, "<relative>"))
    return found


def wing_violations(root: Path) -> list[str]:
    """Every import under the package folder ``root`` that breaks the wings' rules, as ``file:line: why``."""
    package = root.name
    faces = {}
    for wing in WINGS:
        init = root / wing / "__init__.py"
        if init.exists():
            faces[wing] = set(_dunder_all(ast.parse(init.read_text())))
    problems = []
    for path in sorted(root.rglob("*.py")):
        module = _module_name(path, root)
        here = _wing(module)
        for line, target in _imported(ast.parse(path.read_text()), package):
            where = f"{path.relative_to(root.parent)}:{line}"
            if target == "<relative>":
                problems.append(f"{where}: a relative import (write the module's full name)")
                continue
            there = _wing(target)
            if there is None or there == here:
                continue
            if here is None:
                problems.append(f"{where}: base module {module} imports {target} from the {there} wing")
            elif WINGS.index(there) > WINGS.index(here):
                problems.append(f"{where}: the {here} wing imports {target} from the higher {there} wing")
            elif target.split(".")[2] not in faces.get(there, set()):
                problems.append(
                    f"{where}: {target} is not in the {there} wing's __all__ {sorted(faces[there])}"
                )
    return problems


def _dunder_all(tree: ast.Module) -> list[str]:
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "__all__" for t in node.targets):
            return list(ast.literal_eval(node.value))
    return []


def test_the_wings_import_only_downward_and_through_their_public_faces():
    assert wing_violations(PACKAGE) == []


def test_every_wing_says_what_it_is_and_names_its_public_modules():
    for wing in WINGS:
        init = ast.parse((PACKAGE / wing / "__init__.py").read_text())
        assert ast.get_docstring(init), f"{wing}/__init__.py has no docstring"
        for name in _dunder_all(init):
            assert (PACKAGE / wing / f"{name}.py").exists() or (PACKAGE / wing / name).is_dir(), (wing, name)


def _write(root: Path, relative: str, text: str) -> None:
    path = root / relative
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_an_upward_or_private_import_is_caught(tmp_path):
    root = tmp_path / "pkg"
    _write(root, "__init__.py", "")
    _write(root, "errors.py", "")
    _write(root, "evolution/__init__.py", '"""e"""\n__all__ = ["run"]\n')
    _write(root, "evolution/run.py", "from pkg.errors import X\n")
    _write(root, "evolution/operators.py", "")
    _write(root, "viewing/__init__.py", '"""v"""\n__all__ = ["figures"]\n')
    _write(root, "viewing/figures.py", "from pkg.evolution.run import Run\n")
    assert wing_violations(root) == []
    _write(root, "evolution/archive.py", "def f():\n    from pkg.viewing import figures\n")  # upward, lazily
    _write(root, "viewing/explorer.py", "from pkg.evolution.operators import mutate\n")  # not public
    _write(root, "errors.py", "import pkg.viewing.figures\n")  # a base module into a wing
    problems = wing_violations(root)
    assert len(problems) == 3, problems
    said = "\n".join(problems)
    assert "archive.py:2: the evolution wing imports pkg.viewing.figures from the higher viewing wing" in said
    assert "errors.py:1: base module pkg.errors imports pkg.viewing.figures" in said
    assert "explorer.py:1: pkg.evolution.operators is not in the evolution wing's __all__" in said


def test_the_ros_free_wings_load_no_rclpy():
    modules = sorted(
        _module_name(path, PACKAGE) for wing in ROS_FREE for path in (PACKAGE / wing).rglob("*.py")
    ) + sorted(_module_name(path, PACKAGE) for path in PACKAGE.glob("*.py"))
    code = (
        "import importlib, sys\n"
        f"for name in {modules!r}:\n"
        "    importlib.import_module(name)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('rclpy', 'swarm_msgs')))\n"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "[]", f"importing the ROS-free wings loaded: {loaded}"
    assert len(modules) > 25  # every module of those wings was imported, not an empty list
