"""What can be achieved before a design: fault signatures, least orders, isolability.

* :mod:`~geomfdi.synthesis.specification.signatures` -- ``achievable_structures``,
  ``achievable_signatures``: every achievable structure-matrix row, weak and strong
  (Varga's ``fdigenspec``).
* :mod:`~geomfdi.synthesis.specification.orders` -- ``structure_orders``: the least order
  of a scalar residual for each row of a structure matrix (Varga's ``fdichkspec``).
* :mod:`~geomfdi.synthesis.specification.isolability` -- ``isolability_analysis``: faults
  that can never be told apart, columns contained in others, and a suggested structure.
* :mod:`~geomfdi.synthesis.specification.model` -- the column-normalised model and the
  quotient every analysis decides on.

See the user guide, *Choosing a structure* (``docs/guide/choosing-a-structure.md``).

These modules may import :mod:`geomfdi.model`, :mod:`geomfdi.geometry` and
:mod:`geomfdi.synthesis.least_order` (the quotient and the degree search the design uses),
never the synthesis front end (``design``, ``build``, ``construction``); the front end
imports :func:`~geomfdi.synthesis.specification.isolability.identical_columns` inside
``design_bank`` for its warning.
"""
