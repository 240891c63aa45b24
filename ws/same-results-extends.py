"""Whether a result file written here only extends the one an earlier commit wrote (ws/same-results).

    python ws/same-results-extends.py REV_FILE TREE_FILE

Exit 0 and print what was added when every value of REV_FILE is in TREE_FILE with the same text: a CSV may
add columns, a JSON document keys and trailing list entries. Exit 1 with the first difference otherwise.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path


def _csv(rev: Path, tree: Path) -> str:
    with rev.open(newline="") as a, tree.open(newline="") as b:
        old, new = list(csv.reader(a)), list(csv.reader(b))
    if len(old) != len(new) or not old:
        raise ValueError(f"{len(old)} rows there, {len(new)} here")
    missing = [c for c in old[0] if c not in new[0]]
    if missing:
        raise ValueError(f"columns gone: {missing}")
    where = [new[0].index(c) for c in old[0]]
    for r, (a_row, b_row) in enumerate(zip(old, new, strict=True)):
        if [b_row[i] for i in where] != a_row:
            raise ValueError(f"row {r} differs")
    return "columns " + ", ".join(c for c in new[0] if c not in old[0])


def _json(old: object, new: object, where: str, added: list[str]) -> None:
    if isinstance(old, dict) and isinstance(new, dict):
        for key in old:
            if key not in new:
                raise ValueError(f"{where}.{key} gone")
            _json(old[key], new[key], f"{where}.{key}", added)
        added.extend(f"{where}.{key}" for key in new if key not in old)
    elif isinstance(old, list) and isinstance(new, list):
        if len(new) < len(old):
            raise ValueError(f"{where}: {len(old)} entries there, {len(new)} here")
        for i, item in enumerate(old):
            _json(item, new[i], f"{where}[{i}]", added)
        if len(new) > len(old):
            added.append(f"{where}[{len(old)}:]")
    elif json.dumps(old) != json.dumps(new):
        raise ValueError(f"{where}: {json.dumps(old)[:60]} there, {json.dumps(new)[:60]} here")


def main() -> int:
    rev, tree = Path(sys.argv[1]), Path(sys.argv[2])
    try:
        if rev.suffix == ".csv":
            print(_csv(rev, tree))
        else:
            added: list[str] = []
            _json(json.loads(rev.read_text()), json.loads(tree.read_text()), "", added)
            names = {a.rsplit(".", 1)[-1] if "[" not in a else "trailing list entries" for a in added}
            print(f"{len(added)} additions: " + ", ".join(sorted(names)[:6]))
    except (ValueError, OSError) as error:
        print(f"{tree.name}: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
