"""numpy's standard normals of a PCG64 generator, three times faster: the same bits.

:func:`standard_normal` fills an array with exactly what
``rng.standard_normal(out=out)`` writes, and leaves ``rng`` in exactly the state that
call leaves it in, for the PCG64 generators of ``numpy.random.default_rng`` (the
measurement and process noise of :class:`~geomfdi.simulation.noise.Noise` with
``generator="numpy"``).  numpy's ziggurat (Marsaglia & Tsang 2000, 256 layers) takes
one 64-bit output ``r`` of PCG64 (O'Neill 2014) per normal:

.. math::

    i = r \\bmod 256, \\quad m = \\lfloor r / 2^9 \\rfloor \\bmod 2^{52}, \\quad
    x = \\pm m\\, w_i \\ \\text{(sign: bit 8 of } r\\text{)}, \\quad
    \\text{returned when } m < k_i,

98.5 % of the draws; the others go through a rejection step that draws more outputs.
numpy runs it through a function pointer per output and per normal (about 11 ns a
normal on the reference machine); the compiled loop ``pcg64_normal.c`` steps PCG64
inline and takes the accepted draws itself (about 3.3 ns), and hands each other draw to
numpy's own ``random_standard_normal`` (the running numpy's function, exported by
``numpy.random._generator``) with a bit generator that replays the draw's output before
continuing the state: the rejection steps are numpy's code, so the values and the final
state are numpy's by construction.  The tables :math:`w_i` and :math:`k_i` are read
from that same function when the library loads (:math:`w_i` is the normal of
:math:`m = 1`; :math:`k_i` the first :math:`m` it rejects, by bisection), then checked:
the draws of a few seeds must equal ``rng.standard_normal``'s bit for bit.

Anything else draws with numpy itself: another bit generator, an ``out`` that is not a
C-contiguous float64 array, fewer than :data:`MIN_DRAWS` normals (reading and writing
the generator's state costs about 10 microseconds), the numpy backend
(``GEOMFDI_SIM_BACKEND=numpy``), no C compiler, a numpy without the function or whose
normals the check finds different (one :class:`~geomfdi.errors.BackendFallbackWarning`
for the last three).  See the user guide, *Performance* (``docs/guide/performance.md``).
"""

from __future__ import annotations

import ctypes
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._cbuild import load_kernel, typed
from geomfdi.errors import BackendFallbackWarning

__all__ = ["MIN_DRAWS", "compiled", "standard_normal"]

#: Fewer normals than this are drawn by numpy (the state's round trip costs more).
MIN_DRAWS = 2048

_NAME = "gfpcg"
_SOURCE = Path(__file__).with_name("pcg64_normal.c")
_LO = (1 << 64) - 1
_CHECK_SEEDS = (0, 1, 2024)
_CHECK_DRAWS = 1 << 16


def _numpy_normal() -> int:
    """Address of numpy's ``random_standard_normal`` (``AttributeError``: not exported)."""
    import numpy.random._generator as gen

    return ctypes.cast(ctypes.CDLL(gen.__file__).random_standard_normal, ctypes.c_void_p).value


def _bind(dll: Any) -> tuple[Any, int] | None:
    """The fill function and numpy's normal, once the tables are read and checked."""
    try:
        fn = _numpy_normal()
    except (AttributeError, OSError) as exc:
        _fallback(f"numpy's random_standard_normal not found ({exc})")
        return None
    if typed(dll.gfpcg_probe, "v")(fn) != 0:
        _fallback("numpy's ziggurat is not the one this kernel knows")
        return None
    lib = typed(dll.gfpcg_fill, "vviv", ctypes.c_int64), fn
    if not _agrees(lib):
        _fallback("its normals differ from numpy's")
        return None
    return lib


def _agrees(lib: tuple[Any, int]) -> bool:
    """Whether the compiled draws of a few seeds equal numpy's bit for bit, and leave
    the generators in the same state."""
    for seed in _CHECK_SEEDS:
        a, b = np.random.default_rng(seed), np.random.default_rng(seed)
        theirs, mine = a.standard_normal(_CHECK_DRAWS), np.empty(_CHECK_DRAWS)
        _fill(b, mine, lib)
        if not (
            np.array_equal(mine.view(np.uint64), theirs.view(np.uint64))
            and a.bit_generator.state == b.bit_generator.state
        ):
            return False
    return True


def _fallback(why: str) -> None:
    warnings.warn(
        f"backend: the compiled draws of numpy's normals are off: {why}; numpy draws them",
        BackendFallbackWarning,
        stacklevel=6,
    )


def _no_compiler(exc: Exception) -> None:
    _fallback(str(exc))


def _kernel() -> tuple[Any, int] | None:
    from geomfdi.simulation.compiled_recursion import sim_backend

    if sim_backend() != "c":
        return None
    return load_kernel(_NAME, _SOURCE, _bind, on_fail=_no_compiler)


def compiled() -> bool:
    """Whether :func:`standard_normal` can run the compiled loop (backend ``"c"``, the
    library built and checked)."""
    return _kernel() is not None


def _fill(rng: np.random.Generator, out: np.ndarray, lib: tuple[Any, int]) -> None:
    fill, fn = lib
    bg = rng.bit_generator
    with bg.lock:  # numpy's own draws hold it: the state read, advanced and written back
        state = bg.state
        pcg = state["state"]
        s, c = pcg["state"], pcg["inc"]
        st = np.array([s & _LO, s >> 64, c & _LO, c >> 64], dtype=np.uint64)
        fill(fn, st.ctypes.data, out.size, out.ctypes.data)
        pcg["state"] = int(st[0]) | (int(st[1]) << 64)
        bg.state = state


def standard_normal(rng: np.random.Generator, out: np.ndarray) -> np.ndarray:
    """``rng.standard_normal(out=out)``: the same values and the same final state of
    ``rng`` (module docstring), drawn by the compiled loop when it applies.

    Parameters
    ----------
    rng : numpy.random.Generator
    out : ndarray of float64
        Filled in place.

    Returns
    -------
    ndarray
        ``out``.
    """
    lib = None
    if (
        out.size >= MIN_DRAWS
        and isinstance(rng.bit_generator, np.random.PCG64)
        and out.dtype == np.float64
        and out.flags.c_contiguous
        and out.flags.writeable
    ):
        lib = _kernel()
    if lib is None:
        return rng.standard_normal(out=out)
    _fill(rng, out, lib)
    return out
