"""Least-order residual rows: the machinery behind ``method="exact"`` (the default).

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``).

* :mod:`~geomfdi.synthesis.least_order.quotient` -- the decoupled quotient of a row (S*).
* :mod:`~geomfdi.synthesis.least_order.search` -- the degree search over the parity spaces
  of the quotient, the least-order certificate (:class:`LeastOrderRow`) and the
  realisation on the plant.
* :mod:`~geomfdi.synthesis.least_order.strong` -- the least degree whose parity space
  responds to every target at given frequencies (strong detection, for
  ``structure_orders(…, frequencies=…)``).
* :mod:`~geomfdi.synthesis.least_order.parity_spaces` -- high-degree parity spaces in an
  orthonormal rational basis; :mod:`~geomfdi.synthesis.least_order.rational_basis` --
  output-normal rational bases and their sampling frequencies.
* :mod:`~geomfdi.synthesis.least_order.quotient_observer` -- a row realised as the
  observer of the whole quotient, with the stabilising output injection of
  :mod:`~geomfdi.synthesis.least_order.injection`.
* :mod:`~geomfdi.synthesis.least_order.orthonormal_row` -- a single-output row realised in
  an orthonormal rational basis (no injection gain).
* :mod:`~geomfdi.synthesis.least_order.poles` -- pole lists;
  :mod:`~geomfdi.synthesis.least_order.placement` -- Schur pole placement (Varga 1981).

These modules may import :mod:`geomfdi.model`, :mod:`geomfdi.geometry`,
:mod:`geomfdi.generators` and one another, never the synthesis front end
(:mod:`geomfdi.synthesis.design`, ``build``, ``multirow``, ``construction``).
"""

from __future__ import annotations

from typing import Any


def __getattr__(name: str) -> Any:
    # ``geomfdi.synthesis.least_order`` was one module; its names now live in ``.search``.
    import importlib
    import warnings

    search = importlib.import_module("geomfdi.synthesis.least_order.search")
    if name.startswith("__") or not hasattr(search, name):
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(
        f"geomfdi.synthesis.least_order.{name} moved to "
        f"geomfdi.synthesis.least_order.search.{name}",
        DeprecationWarning,
        stacklevel=2,
    )
    return getattr(search, name)
