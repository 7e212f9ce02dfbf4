"""C99 code for a deployed residual monitor: ``gf.codegen.c(monitor_or_bank, name, out_dir)``.

Writes ``name.h`` and ``name.c``: static constant tables (floats as exact hexadecimal
literals), a caller-owned state struct, no ``malloc`` and nothing from ``libm`` but
``fabs`` and ``sqrt``.  The functions::

    void name_init(name_state *s);
    int  name_step(name_state *s, const double *y, const double *u,
                   double *r, int *alarms);          /* returns the isolation decision */
    void name_run(name_state *s, long n, const double *Y, const double *U,
                  double *R, int *A, int *I);         /* n samples, row-major */
    unsigned long name_state_size(void);

run the algorithm of :mod:`geomfdi.deployment.codegen._spec` (the one of
:class:`geomfdi.Monitor`): fused generator recursion, start-up and missing-sample rules,
thresholds, k-of-n persistence and isolation on the bank's structure.  See the user
guide, *Theory: residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from geomfdi.deployment.codegen._c_text import c_source
from geomfdi.deployment.codegen._source import code_spec
from geomfdi.deployment.codegen._spec import check_name, check_out_dir

__all__ = ["c", "c_source"]


def c(
    source: Any,
    name: str,
    out_dir: str | Path,
    *,
    threshold: Any = None,
    persistence: Any = None,
    initial: Any = "steady",
) -> tuple[Path, Path]:
    """Write ``name.h`` and ``name.c`` for a monitor or a discrete bank.

    Parameters
    ----------
    source : Monitor or ResidualBank
        A :class:`~geomfdi.Monitor` (its threshold, persistence and start-up rule are
        used) or a discrete bank (then ``threshold``, ``persistence``, ``initial`` as for
        :class:`~geomfdi.Monitor`).
    name : str
        C identifier prefix of the files, types and functions.
    out_dir : path
        Created if needed.

    Returns
    -------
    (Path, Path)
        The header and the source file.

    Raises
    ------
    NotDiscreteError
        For a continuous bank (sample it with ``bank.discretize(dt)``).
    """
    name = check_name(name)
    out_dir = check_out_dir(out_dir)
    spec = code_spec(source, threshold=threshold, persistence=persistence, initial=initial)
    h, src = c_source(spec, name)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    hp, cp = out / f"{name}.h", out / f"{name}.c"
    hp.write_text(h, encoding="utf-8")
    cp.write_text(src, encoding="utf-8")
    return hp, cp
