"""Old module paths that still import, as aliases of the modules that now hold the code.

``import geomfdi.synthesis.generator`` (say) returns the module
:mod:`geomfdi.generators.generator` itself, after a :class:`DeprecationWarning` naming the
new path; ``from geomfdi.synthesis.generator import ResidualBank`` therefore gives the same
class as ``from geomfdi.generators import ResidualBank``.  The finder answers only for the
names in :data:`MOVED`; it is installed on ``import geomfdi``.

Renamed public names work the same way: :func:`renamed` gives a module the
``__getattr__`` that returns the new object for an old name, after a
:class:`DeprecationWarning` naming the new one.
"""

from __future__ import annotations

import importlib
import importlib.machinery
import sys
import warnings
from collections.abc import Callable
from types import ModuleType
from typing import Any

__all__ = ["MOVED", "RENAMED", "install", "renamed"]

MOVED: dict[str, str] = {
    "geomfdi.synthesis.generator": "geomfdi.generators.generator",
    "geomfdi.synthesis.bankfile": "geomfdi.generators.bankfile",
    "geomfdi.synthesis.discretize": "geomfdi.generators.discretize",
    "geomfdi.synthesis.realization": "geomfdi.generators.realization",
    "geomfdi.synthesis.exact_generator": "geomfdi.generators.exact",
    "geomfdi.synthesis.gains": "geomfdi.generators.gains",
    "geomfdi.synthesis.quotient": "geomfdi.synthesis.least_order.quotient",
    "geomfdi.synthesis.quotient_observer": "geomfdi.synthesis.least_order.quotient_observer",
    "geomfdi.synthesis.rational_basis": "geomfdi.synthesis.least_order.rational_basis",
    "geomfdi.synthesis.injection": "geomfdi.synthesis.least_order.injection",
    "geomfdi.synthesis.placement": "geomfdi.synthesis.least_order.placement",
    "geomfdi.synthesis.poles": "geomfdi.synthesis.least_order.poles",
    "geomfdi.synthesis.parity_onb": "geomfdi.synthesis.least_order.parity_spaces",
    "geomfdi.synthesis.orthonormal": "geomfdi.synthesis.least_order.orthonormal_row",
    "geomfdi.synthesis.exact_design": "geomfdi.synthesis.exact.design",
    "geomfdi.synthesis.transforms": "geomfdi.synthesis.sensor_transforms",
    "geomfdi.synthesis.decisions": "geomfdi.synthesis.rank_decisions",
    "geomfdi.parity.seed004": "geomfdi.parity.dodecahedron_experiment",
    "geomfdi.verification.norms": "geomfdi.generators.norms",
}
"""Old module path -> the module that now holds its code."""

RENAMED: dict[str, str] = {
    "seed004_experiment": "qin_niu_experiment",
    "Seed004Result": "QinNiuResult",
    "plot_seed004": "plot_qin_niu",
    "SEED004_KINDS": "QIN_NIU_KINDS",
    "SEED004_METHODS": "QIN_NIU_METHODS",
}
"""Old public name -> its new name (the experiment of Qin & Niu 1999)."""


def renamed(module: str, names: dict[str, str] | None = None) -> Callable[[str], Any]:
    """A module ``__getattr__`` answering the old names of :data:`RENAMED` (or ``names``).

    Parameters
    ----------
    module : str
        The module's ``__name__``; the new object is read from it.
    names : dict, optional
        Old name -> new name; by default the entries of :data:`RENAMED`.

    Returns
    -------
    callable
        ``__getattr__(name)``: the object now called ``names[name]``, after a
        :class:`DeprecationWarning`; :class:`AttributeError` for any other name.
    """
    table = RENAMED if names is None else names

    def __getattr__(name: str) -> Any:
        new = table.get(name)
        if new is None or not hasattr(sys.modules[module], new):
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        warnings.warn(
            f"{module}.{name} is deprecated; use {module}.{new}", DeprecationWarning, stacklevel=2
        )
        return getattr(sys.modules[module], new)

    return __getattr__


class _AliasLoader:
    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
        return None

    def exec_module(self, module: ModuleType) -> None:
        old = module.__name__
        new = MOVED[old]
        warnings.warn(f"{old} is deprecated; import from {new}", DeprecationWarning, stacklevel=2)
        # the import system returns what sys.modules holds under the old name
        sys.modules[old] = importlib.import_module(new)


class _AliasFinder:
    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname not in MOVED:
            return None
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader())


_FINDER = _AliasFinder()


def install() -> None:
    """Put the alias finder on :data:`sys.meta_path` (once)."""
    if not any(isinstance(f, _AliasFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _FINDER)
