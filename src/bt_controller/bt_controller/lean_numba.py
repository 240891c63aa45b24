"""numba started without two optional libraries that no kernel of the workspace uses: a faster start for
every command that compiles or loads a kernel (``swarm_sim evaluate --tree forward``: 1.75 s of CPU before,
1.4 s after, at load 9 on 2 cores).

The first time numba compiles or loads a function it imports its extensions, and two of them probe for an
optional library at import: ``numba.np.arraymath`` imports ``scipy.linalg`` (whether a BLAS backs
``np.convolve`` and ``np.correlate``), and ``numba.core.typing.cffi_utils`` imports ``cffi`` (to type CFFI
functions). Importing this module imports those two extensions with ``scipy.linalg`` and ``cffi`` hidden,
so the probes answer "absent"; the kernels use neither. Afterwards both import normally (``scipy.stats`` in
the evolution manager), and numba's linear algebra (``np.dot``, ``np.linalg``) still works: it looks for
scipy again when it compiles. If either library was imported before this module, nothing is hidden.

Every module of the package that defines numba functions imports this module, so it runs before any of them
is compiled or loaded.
"""

from __future__ import annotations

import importlib
import sys

HIDDEN = ("scipy.linalg", "cffi")
"""The libraries hidden from numba's optional probes."""


def _start() -> None:
    hidden = [name for name in HIDDEN if name not in sys.modules]
    for name in hidden:
        sys.modules[name] = None  # type: ignore[assignment]  # None in sys.modules: `import name` fails
    try:
        importlib.import_module("numba.core.typing.cffi_utils")
        importlib.import_module("numba.np.arraymath")
    finally:
        for name in hidden:
            if sys.modules.get(name, "") is None:
                del sys.modules[name]


_start()
