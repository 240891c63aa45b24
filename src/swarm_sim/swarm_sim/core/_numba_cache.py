"""Keep numba's on-disk cache honest across modules.

numba keys a cached function on its own source file only: when ``world.py`` changes, a kernel in ``kernel.py``
that inlined the old ``world`` functions is still loaded from the cache, and the two roads silently disagree.
``drop_stale_cache`` fixes that: called at import of a module with the files its compiled code depends on, it
removes the module's cache files (in the ``__pycache__`` next to it, numba's default place) whenever those
files' contents changed since the cache was written.
"""

from __future__ import annotations

import hashlib
import importlib.util
from collections.abc import Sequence
from pathlib import Path


def _module_file(name: str) -> Path:
    spec = importlib.util.find_spec(name)
    if spec is None or spec.origin is None:
        raise ImportError(f"cannot locate module {name}")
    return Path(spec.origin)


def drop_stale_cache(module_file: str, dependencies: Sequence[str]) -> None:
    """Remove ``module_file``'s numba cache if any module in ``dependencies`` (dotted names) changed."""
    digest = hashlib.sha256()
    for name in sorted(dependencies):
        digest.update(name.encode())
        digest.update(_module_file(name).read_bytes())
    fingerprint = digest.hexdigest()
    source = Path(module_file)
    cache_dir = source.parent / "__pycache__"
    stamp = cache_dir / f"{source.stem}.dependencies"
    try:
        if stamp.read_text() == fingerprint:
            return
    except OSError:
        pass
    try:
        for cached in cache_dir.glob(f"{source.stem}.*.nb[ic]"):
            cached.unlink(missing_ok=True)
        cache_dir.mkdir(exist_ok=True)
        stamp.write_text(fingerprint)
    except OSError:
        pass  # a read-only install: its cache was written from these very files
