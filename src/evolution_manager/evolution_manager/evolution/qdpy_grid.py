"""qdpy's ``Grid`` and phenotype classes, imported without scikit-learn.

``qdpy.containers`` (0.1.2.2) imports ``sklearn.cluster.KMeans`` and ``sklearn.gaussian_process`` at module
level for its ``CVTGrid`` only; that pulls in scikit-learn and most of SciPy, about 3.5 s of every start-up.
This project uses the plain ``Grid``. While qdpy's containers are imported, the two scikit-learn modules are
stood in for by modules whose classes import the real ones when first used, so nothing qdpy does changes; the
stand-ins are removed from ``sys.modules`` afterwards, so a later ``import sklearn.cluster`` is the real one.
"""

from __future__ import annotations

import importlib
import sys
import types

_DEFERRED: dict[str, tuple[str, ...]] = {
    "sklearn.cluster": ("KMeans",),
    "sklearn.gaussian_process": ("GaussianProcessRegressor",),
}


class DeferredClass:
    """Stands for ``module.name`` in qdpy's namespace; imports the real class on first use."""

    def __init__(self, module: str, name: str) -> None:
        self._module = module
        self._name = name

    def real(self) -> type:
        """The real class (imports its module)."""
        return getattr(importlib.import_module(self._module), self._name)

    def __call__(self, *args: object, **kwargs: object) -> object:
        return self.real()(*args, **kwargs)

    def __getattr__(self, attribute: str) -> object:
        return getattr(self.real(), attribute)


def _import_containers() -> types.ModuleType:
    if "qdpy.containers" in sys.modules:
        return sys.modules["qdpy.containers"]
    stand_ins = {}
    for module, names in _DEFERRED.items():
        if module not in sys.modules:  # already imported for real: qdpy gets the real one
            stand_in = types.ModuleType(
                module, "stand-in until first use (evolution_manager.evolution.qdpy_grid)"
            )
            for name in names:
                setattr(stand_in, name, DeferredClass(module, name))
            stand_ins[module] = stand_in
    sys.modules.update(stand_ins)
    try:
        return importlib.import_module("qdpy.containers")
    finally:
        for module, stand_in in stand_ins.items():
            if sys.modules.get(module) is stand_in:
                del sys.modules[module]


Grid = _import_containers().Grid

from qdpy.phenotype import Features, Fitness, Individual, ScoresDict  # noqa: E402  (after the containers)

__all__ = ["DeferredClass", "Features", "Fitness", "Grid", "Individual", "ScoresDict"]
