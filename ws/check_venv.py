"""Check that a virtual environment holds exactly the pinned requirements, with every installed file present.

Usage: python ws/check_venv.py REQUIREMENTS_TXT
Exits 0 when the environment is whole; otherwise prints the first problems found and exits 1. Run by ws/setup
on every call: it takes a fraction of a second and catches an environment deleted half-way, a package missing
or at the wrong version, and files removed from inside an installed package.
"""

from __future__ import annotations

import re
import sys
from importlib import metadata
from pathlib import Path


def normalise(name: str) -> str:
    """PEP 503 normalised distribution name."""
    return re.sub(r"[-_.]+", "-", name).lower()


def pinned(requirements: Path) -> dict[str, str]:
    """Map of normalised name to version for every `name==version` line of a lock file."""
    pins = {}
    for line in requirements.read_text().splitlines():
        match = re.match(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==([^\s;#]+)", line)
        if match:
            pins[normalise(match[1])] = match[2]
    return pins


def problems(requirements: Path) -> list[str]:
    """Everything that differs between the lock file and the running environment."""
    found = []
    installed = {normalise(d.metadata["Name"]): d for d in metadata.distributions()}
    for name, version in sorted(pinned(requirements).items()):
        dist = installed.get(name)
        if dist is None:
            found.append(f"{name}=={version} is not installed")
        elif dist.version != version:
            found.append(f"{name} is {dist.version}, the lock pins {version}")
        else:
            for file in dist.files or ():
                if not Path(str(file.locate())).exists():
                    found.append(f"{name}: {file} is missing")
                    break
    return found


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    found = problems(Path(sys.argv[1]))
    for line in found[:10]:
        print(f"check_venv: {line}", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
