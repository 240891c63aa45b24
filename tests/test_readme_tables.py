"""Each package README's "Where things are" table names every module of the package, and only real ones."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parent.parent / "src"
PACKAGES = ("bt_controller", "swarm_sim", "evolution_manager", "swarm_ros")


def _modules(package: str) -> set[str]:
    root = SRC / package / package
    return {
        str(path.relative_to(root).with_suffix(""))
        for path in root.rglob("*.py")
        if path.name != "__init__.py"
    }


def _table(package: str) -> set[str]:
    text = (SRC / package / "README.md").read_text()
    section = text.split("## Where things are", 1)[1].split("\n## ", 1)[0]
    named: set[str] = set()
    for line in section.splitlines():
        if line.startswith("| `"):
            named.update(re.findall(r"`([\w/]+)`", line.split("|")[1]))
    return named


@pytest.mark.parametrize("package", PACKAGES)
def test_the_table_names_every_module_and_nothing_else(package):
    modules, named = _modules(package), _table(package)
    assert modules - named == set(), f"{package}/README.md does not name these modules"
    assert named - modules == set(), f"{package}/README.md names modules that do not exist"
