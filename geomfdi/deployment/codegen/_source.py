"""The monitor a code generator writes: a :class:`~geomfdi.Monitor` as given, or one
built on a discrete bank with the threshold, persistence and start-up rule given.

The front end of :func:`geomfdi.codegen.c` and :func:`geomfdi.codegen.python`; the spec
itself is the plain function :func:`geomfdi.deployment.codegen._spec.monitor_spec` of the
monitor record, which ``Monitor(backend="c")`` calls without coming back here.
"""

from __future__ import annotations

from typing import Any

from geomfdi.deployment.codegen._spec import CodeSpec, monitor_spec
from geomfdi.errors import NotDiscreteError

__all__ = ["code_spec"]


def code_spec(
    source: Any,
    *,
    threshold: Any = None,
    persistence: Any = None,
    initial: Any = "steady",
) -> CodeSpec:
    """The :class:`CodeSpec` of a :class:`~geomfdi.Monitor` or a discrete bank.

    A monitor carries its own threshold, persistence and start-up rule; for a bank they
    are given here (as for :class:`~geomfdi.Monitor`).
    """
    from geomfdi.deployment.monitor import Monitor

    if isinstance(source, Monitor):
        return monitor_spec(source)
    from geomfdi.deployment.program import as_bank

    bank = as_bank(source)
    if bank.dt <= 0:
        raise NotDiscreteError(
            "bank: code is generated for discrete banks only; sample this continuous "
            "bank first with bank.discretize(dt) (or design on a discrete plant)",
            argument="bank",
        )
    mon = Monitor(bank, threshold=threshold, persistence=persistence, initial=initial)
    return monitor_spec(mon)
