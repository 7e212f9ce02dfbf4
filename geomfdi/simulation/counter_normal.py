"""Counter-based standard normals: Philox4x32-10 and Box–Muller, in C and in numpy.

The noise generator ``"counter"`` of :class:`~geomfdi.simulation.noise.Noise`: the
standard normal of a run, a stream (measurement, process, plant noise inputs), a row and
a sample index is a pure function of these four numbers,

1. the run's key ``(k0, k1)`` and tag ``c`` (30 bits), the first three 32-bit words of
   ``SeedSequence(seed).generate_state`` (:func:`run_key`);
2. Philox4x32-10 (Salmon, Moraes, Dror & Shaw 2011) of the counter
   ``(j mod 2^32, j div 2^32, row, 4 c + stream)`` with that key, ``j = g div 2`` the
   sample pair of sample ``g``: four words ``x0 .. x3``;
3. the uniforms ``u = ((w >> 11) + 1) 2^-53`` in (0, 1] of ``w = x1 2^32 + x0`` and
   ``v`` of ``x3 2^32 + x2``;
4. Box & Muller (1958): sample ``2j`` is ``sqrt(-2 log u) cos(2 pi v)``, sample
   ``2j + 1`` is ``sqrt(-2 log u) sin(2 pi v)``, with the polynomial ``log``, ``sin``
   and ``cos`` of :data:`LOG_COEFS`, :data:`SIN_COEFS` and :data:`COS_COEFS`
   (polynomials of degree 6 interpolating at Chebyshev nodes, summed by Estrin's
   scheme; ``log`` after the reduction ``u = 2^k m``, ``m`` in ``[sqrt(2)/2, sqrt(2))``;
   ``sin`` and ``cos`` after taking the nearest quarter turn from ``4 v`` itself,
   exactly).

:func:`fill_normals` runs the compiled kernel ``counter_normal.c`` (built like the batch
recursion, :mod:`geomfdi._cbuild`, without fused multiply-adds) and falls back to
:func:`numpy_normals`, which performs the same IEEE-754 operations in the same order
(``GEOMFDI_SIM_BACKEND=numpy``, or no C compiler: one
:class:`~geomfdi.errors.BackendFallbackWarning`): both give the same bits, on every
machine.  See the user guide, *Simulation* (``docs/guide/simulation.md``, noise
generators) and *Performance* (``docs/guide/performance.md``).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._cbuild import load_kernel, typed
from geomfdi.errors import BackendFallbackWarning, GeomFDIError

__all__ = [
    "COS_COEFS",
    "LOG_COEFS",
    "SIN_COEFS",
    "STREAMS",
    "fill_normals",
    "numpy_normals",
    "philox4x32",
    "run_key",
]

#: Stream numbers of the counter (its last word's two low bits).
STREAMS = {"measurement": 0, "process": 1, "inputs": 2}

_M0, _M1 = np.uint64(0xD2511F53), np.uint64(0xCD9E8D57)  # Philox4x32 multipliers
_W0, _W1 = np.uint64(0x9E3779B9), np.uint64(0xBB67AE85)  # key increments (Weyl)
_LO32 = np.uint64(0xFFFFFFFF)
_ROUNDS = 10


def _hex(*literals: str) -> tuple[float, ...]:
    """Doubles from C99 hexadecimal literals (exact: no decimal rounding)."""
    return tuple(float.fromhex(h) for h in literals)


#: ``P`` of ``R = z P(z)``, ``z = s^2``: ``P(z) ~ (2 atanh(s) / s - 2) / z``, degree 6,
#: interpolating at the Chebyshev nodes of ``0 <= z <= (3 - 2 sqrt(2))^2`` (40 digits,
#: rounded to double; relative error of ``log`` below 5e-18 before rounding).
LOG_COEFS = _hex(
    "0x1.5555555555558p-1", "0x1.99999999952e2p-2", "0x1.2492492df148dp-2",
    "0x1.c71c62e5800a1p-3", "0x1.7462b4ab2ef6bp-3", "0x1.39fe606542ddep-3",
    "0x1.2b584aae78a57p-3",
)  # fmt: skip
_LN2_HI = float.fromhex("0x1.62e42p-1")  # log 2 with 32 trailing zero bits
_LN2_LO = float.fromhex("0x1.fdf473de6af28p-22")  # log 2 - _LN2_HI
_SQRT2_MANT = 0x6A09E667F3BCD  # mantissa bits of sqrt(2)
#: ``sin(pi r/2) / r`` as a polynomial of degree 6 in ``r^2``, interpolating at the
#: Chebyshev nodes of ``0 <= r^2 <= 1/4`` (40 digits, rounded to double).
SIN_COEFS = _hex(
    "0x1.921fb54442d18p+0", "-0x1.4abbce625be41p-1", "0x1.466bc677587f8p-4",
    "-0x1.32d2cce2e5b19p-8", "0x1.50782fda12d96p-13", "-0x1.e30071afc3e59p-19",
    "0x1.e3f38399551bfp-25",
)  # fmt: skip
#: ``(cos(pi r/2) - 1) / r^2`` as a polynomial of degree 6 in ``r^2`` (the same nodes).
COS_COEFS = _hex(
    "-0x1.3bd3cc9be45dep+0", "0x1.03c1f081b5ac0p-2", "-0x1.55d3c7e3cb241p-6",
    "0x1.e1f5068688d5bp-11", "-0x1.a6d1eef479be1p-16", "0x1.f9ce245cada0bp-22",
    "-0x1.b2f3eb054afcdp-28",
)  # fmt: skip

_NAME = "gfnoise"
#: The kernel's constants, defined here alone (hexadecimal: the same doubles in C).
_DEFINES = tuple(
    f"-DGFN_{name}={','.join(float.hex(c) for c in coefs)}"
    for name, coefs in (
        ("LOG_COEFS", LOG_COEFS),
        ("SIN_COEFS", SIN_COEFS),
        ("COS_COEFS", COS_COEFS),
        ("LN2_HI", (_LN2_HI,)),
        ("LN2_LO", (_LN2_LO,)),
    )
) + (f"-DGFN_SQRT2_MANT={_SQRT2_MANT:#x}",)
_SOURCE = Path(__file__).with_name("counter_normal.c")


def run_key(seed: Any) -> np.ndarray:
    """The key and tag of a run: ``SeedSequence(seed).generate_state(3, uint32)``.

    Parameters
    ----------
    seed : int, numpy SeedSequence or None
        The run's seed (an integer as for ``numpy.random.default_rng``, a sequence such
        as the children of a batch's ``SeedSequence``; ``None``: fresh entropy).

    Returns
    -------
    ndarray, (3,) uint32
        ``k0, k1`` (the Philox key) and the tag (its low 30 bits enter the counter).
    """
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return ss.generate_state(3, np.uint32)


def philox4x32(counter: np.ndarray, key: np.ndarray) -> np.ndarray:
    """Philox4x32-10 (Salmon et al. 2011, section 3.2) of counters under keys, in numpy.

    Parameters
    ----------
    counter : array_like, (..., 4) of uint32
    key : array_like, (..., 2) of uint32 (broadcast against ``counter``)

    Returns
    -------
    ndarray, (..., 4) uint32
        Ten rounds ``(x0, x1, x2, x3) -> (hi(M1 x2) ^ x1 ^ k0, lo(M1 x2),
        hi(M0 x0) ^ x3 ^ k1, lo(M0 x0))``, the key bumped by the Weyl constants
        between rounds.
    """
    c = np.asarray(counter, dtype=np.uint64)
    k = np.asarray(key, dtype=np.uint64)
    x = _philox([c[..., 0], c[..., 1], c[..., 2], c[..., 3]], k[..., 0], k[..., 1])
    return np.stack(x, axis=-1).astype(np.uint32)


def _philox(x: list[Any], ka: Any, kb: Any) -> list[np.ndarray]:
    """The rounds on uint64 arrays holding 32-bit words (broadcasting)."""
    x0, x1, x2, x3 = (np.asarray(w, dtype=np.uint64) for w in x)
    ka, kb = np.asarray(ka, dtype=np.uint64), np.asarray(kb, dtype=np.uint64)
    s32 = np.uint64(32)
    for _ in range(_ROUNDS):
        p0 = _M0 * x0  # < 2^64: x0 < 2^32
        p1 = _M1 * x2
        x0, x1, x2, x3 = (p1 >> s32) ^ x1 ^ ka, p1 & _LO32, (p0 >> s32) ^ x3 ^ kb, p0 & _LO32
        ka = (ka + _W0) & _LO32
        kb = (kb + _W1) & _LO32
    return [x0, x1, x2, x3]


def _estrin7(c: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    """``c[0] + c[1] x + ... + c[6] x^6`` by Estrin's scheme, in the C kernel's order."""
    x2 = x * x
    x4 = x2 * x2
    p01, p23, p45 = c[0] + c[1] * x, c[2] + c[3] * x, c[4] + c[5] * x
    p03, p46 = p01 + x2 * p23, p45 + x2 * c[6]
    return p03 + x4 * p46


def _uniform(w: np.ndarray) -> np.ndarray:
    """``((w >> 11) + 1) 2^-53`` (exact)."""
    return ((w >> np.uint64(11)) + np.uint64(1)).astype(np.float64) * 2.0**-53


def log_unit(u: np.ndarray) -> np.ndarray:
    """``log u`` for ``0 < u <= 1`` (normal numbers) as the C kernel computes it.

    ``u = 2^k m`` with ``m`` in ``[sqrt(2)/2, sqrt(2))``, ``f = m - 1``,
    ``s = f / (2 + f)``, ``log u = k log 2 + f - (f^2/2 - s (f^2/2 + R))`` with ``R`` the
    series of :data:`LOG_COEFS` (``log 2`` in two parts, ``k log 2`` exact in the first).
    """
    u = np.asarray(u, dtype=np.float64)
    bits = u.view(np.uint64)
    mant = bits & np.uint64(0x000FFFFFFFFFFFFF)
    big = (mant > np.uint64(_SQRT2_MANT)).astype(np.uint64)
    m = (mant | ((np.uint64(0x3FF) - big) << np.uint64(52))).view(np.float64)
    k = ((bits >> np.uint64(52)) + big).astype(np.float64) - 1023.0  # exact
    f = m - 1.0
    s = f / (2.0 + f)
    z = s * s
    R = z * _estrin7(LOG_COEFS, z)
    hfsq = 0.5 * f * f
    return k * _LN2_HI - ((hfsq - (s * (hfsq + R) + k * _LN2_LO)) - f)


def quarter_sincos(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(cos(2 pi v), sin(2 pi v))`` of the uniform ``v`` of words ``w``, as the C
    kernel computes them.

    ``4 v = N 2^-51``, ``N = (w >> 11) + 1``: the nearest quarter turn
    ``q = (N + 2^50) >> 51`` and ``r = 4 v - q`` in ``[-1/2, 1/2)`` are exact; the
    polynomials of :data:`SIN_COEFS` and :data:`COS_COEFS` give ``sin(pi r / 2)`` and
    ``cos(pi r / 2)``, the quarter turns ``q`` swap and negate them.
    """
    N = (np.asarray(w, dtype=np.uint64) >> np.uint64(11)).astype(np.int64) + 1
    q = (N + (1 << 50)) >> 51
    k = N - (q << 51)
    big = (k.view(np.uint64) + np.uint64(0x4338000000000000)).view(np.float64)
    r = (big - 6755399441055744.0) * 2.0**-51  # 2^52 + 2^51
    r2 = r * r
    S = r * _estrin7(SIN_COEFS, r2)
    C = 1.0 + r2 * _estrin7(COS_COEFS, r2)
    odd = (q & 1).astype(bool)
    cosb = np.where(odd, S, C).view(np.uint64)
    sinb = np.where(odd, C, S).view(np.uint64)
    sign = np.uint64(1) << np.uint64(63)
    cosb = np.where(((q + 1) & 2).astype(bool), cosb ^ sign, cosb)
    sinb = np.where((q & 2).astype(bool), sinb ^ sign, sinb)
    return cosb.view(np.float64), sinb.view(np.float64)


def _pairs_numpy(
    keys: np.ndarray, stream: int, rows: np.ndarray, j: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(rho cos, rho sin)`` of pairs ``j`` (P,) for keys (R, 3) and rows (I,): (R, I, P)."""
    k = keys.astype(np.uint64)
    ka, kb = k[:, 0, None, None], k[:, 1, None, None]
    tag = ((k[:, 2, None, None] << np.uint64(2)) & _LO32) | np.uint64(stream & 3)
    x0 = (j & _LO32)[None, None, :]
    x1 = (j >> np.uint64(32))[None, None, :]
    x2 = rows.astype(np.uint64)[None, :, None]
    shape = (keys.shape[0], rows.size, j.size)
    x = _philox([np.broadcast_to(a, shape) for a in (x0, x1, x2, tag)], ka, kb)
    a = (x[1] << np.uint64(32)) | x[0]
    b = (x[3] << np.uint64(32)) | x[2]
    rho = np.sqrt(-2.0 * log_unit(_uniform(a)))
    c, s = quarter_sincos(b)
    return rho * c, rho * s


def numpy_normals(
    keys: np.ndarray,
    stream: int,
    row0: int,
    s: int,
    e: int,
    out: np.ndarray,
    rows: int | None = None,
) -> np.ndarray:
    """The normals of samples ``s .. e-1`` in numpy: ``out[r, i, k]`` is the normal of
    key ``r``, ``stream``, row ``row0 + i``, sample ``s + k`` (the C kernel's values).

    Parameters
    ----------
    keys : ndarray, (R, 3) uint32
        :func:`run_key` of every run.
    stream : int
        :data:`STREAMS` value.
    row0 : int
        Row of ``out[:, 0]``.
    s, e : int
        Sample range.
    out : ndarray, (R, I, e - s) float64
        Written in place (any strides) and returned.
    rows : int, optional
        ``I`` (``out.shape[1]``).
    """
    R, I = keys.shape[0], out.shape[1] if rows is None else rows
    if e <= s or R == 0 or I == 0:
        return out
    ridx = np.arange(row0, row0 + I, dtype=np.uint64)
    step = max(1, (1 << 17) // max(R * I, 1))  # pairs per piece: bounded temporaries
    j0, j1 = s >> 1, (e - 1) >> 1
    for a in range(j0, j1 + 1, step):
        b = min(a + step, j1 + 1)
        zc, zs = _pairs_numpy(keys, stream, ridx, np.arange(a, b, dtype=np.uint64))
        z = np.empty((R, I, 2 * (b - a)))
        z[:, :, 0::2], z[:, :, 1::2] = zc, zs
        lo, hi = max(s, 2 * a), min(e, 2 * b)
        out[:, :, lo - s : hi - s] = z[:, :, lo - 2 * a : hi - 2 * a]
    return out


def _bind(dll: Any) -> tuple[Any, Any]:
    """The fill and the raw Philox functions of the library, typed."""
    return typed(dll.gfn_fill, "iiiiiivvii"), typed(dll.gfn_philox, "ivvv", None)


def _no_compiler(exc: Exception) -> None:
    warnings.warn(
        f"{exc}; the counter noise generator runs in numpy (the same values)",
        BackendFallbackWarning,
        stacklevel=5,
    )


def _library() -> Any:
    """The compiled kernel, or ``None`` (no compiler: a :class:`BackendFallbackWarning`).
    Built without errno from ``sqrt``: the square roots run in SIMD instructions (the
    same bits)."""
    return load_kernel(
        _NAME, _SOURCE, _bind, flags=("-fno-math-errno", *_DEFINES), on_fail=_no_compiler
    )


def _kernel() -> Any:
    """The compiled library's functions when the backend is ``"c"`` and it builds."""
    from geomfdi.simulation.compiled_recursion import sim_backend

    return _library() if sim_backend() == "c" else None


def compiled() -> bool:
    """Whether :func:`fill_normals` runs the C kernel (backend ``"c"`` and it builds)."""
    return _kernel() is not None


def compiled_philox(counter: np.ndarray, key: np.ndarray) -> np.ndarray:
    """:func:`philox4x32` through the C kernel (tests: the kernel's own rounds)."""
    lib = _library()
    if lib is None:
        raise GeomFDIError("backend: no working C compiler", argument="backend")
    c = np.ascontiguousarray(np.asarray(counter, dtype=np.uint32).reshape(-1, 4))
    k = np.ascontiguousarray(np.broadcast_to(np.asarray(key, dtype=np.uint32), (len(c), 2)))
    out = np.empty_like(c)
    lib[1](len(c), c.ctypes.data, k.ctypes.data, out.ctypes.data)
    return out.reshape(np.shape(counter))


def fill_normals(
    keys: np.ndarray,
    stream: int,
    row0: int,
    s: int,
    e: int,
    out: np.ndarray,
) -> np.ndarray:
    """Standard normals of samples ``s .. e-1`` into ``out`` (R, I, e - s), in place.

    ``out[r, i, k]`` is the normal of key ``keys[r]`` (:func:`run_key`), ``stream``
    (:data:`STREAMS`), row ``row0 + i`` and sample ``s + k`` (module docstring).  One
    call of the compiled kernel for all runs and rows when ``out``'s samples are
    contiguous (any run and row strides); else, or on the numpy backend,
    :func:`numpy_normals` (the same bits).

    Returns
    -------
    ndarray
        ``out``.
    """
    keys = np.ascontiguousarray(keys, dtype=np.uint32).reshape(-1, 3)
    if out.ndim != 3 or out.shape[0] != keys.shape[0] or out.shape[2] != e - s:
        raise GeomFDIError(
            f"noise: out must be ({keys.shape[0]}, rows, {e - s}), got {out.shape}",
            argument="out",
        )
    if out.size == 0:
        return out
    usable = (
        out.dtype == np.float64
        and out.flags.writeable
        and out.strides[2] == 8
        and all(st % 8 == 0 for st in out.strides)
    )
    lib = _kernel() if usable else None
    if lib is not None:
        fn = lib[0]
        R, I, L = out.shape
        rs, is_ = out.strides[0] // 8, out.strides[1] // 8
        fn(R, I, int(row0), int(stream), int(s), L, keys.ctypes.data, out.ctypes.data, rs, is_)
        return out
    return numpy_normals(keys, stream, row0, s, e, out)
