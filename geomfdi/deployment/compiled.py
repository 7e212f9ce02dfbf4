"""The compiled online path of :class:`geomfdi.Monitor` (``backend="c"``).

The C99 code of :func:`geomfdi.codegen.c` (the same algorithm as the numpy monitor:
fused generator recursion, start-up and missing-sample rules, thresholds, k-of-n
persistence, isolation) is compiled once into a shared library with the system's C
compiler (``$CC``, else ``cc``; for the running processor, without fused multiply-add),
cached under a hash of the source, compiler, flags and processor in the cache directory
(``$GEOMFDI_CACHE_DIR``, else ``$XDG_CACHE_HOME/geomfdi/c`` or ``~/.cache/geomfdi/c``),
and loaded with :mod:`ctypes`.

:meth:`Monitor.feed` is one call of ``name_run`` over the whole chunk (per sample the
generated C step alone, plus a few array passes).  :meth:`Monitor.step` is one call
of a builtin function that the library makes through the C interface of Python and
numpy (when their headers are found): it reads float64 vectors ``y``, ``u`` (also
columns of a record) and returns the :class:`MonitorStep` built in C, without the
argument conversion of a ``ctypes`` call.  Other samples (lists, other dtypes), and
libraries built without those headers, go through ``ctypes`` on preallocated buffers
(:data:`STEP_CALLS` chooses; ``cffi`` is the third way).  The generated code needs a
discrete bank; for a continuous bank, or when no compiler works, :func:`compiled_paths`
returns ``None`` and the monitor keeps its numpy path with a warning.  See the user
guide, *Performance* (``docs/guide/performance.md``).
"""

from __future__ import annotations

import ctypes
import sys
import warnings
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._cbuild import build_library as _build
from geomfdi._cbuild import cache_dir
from geomfdi.errors import BackendFallbackWarning, GeomFDIError, ShapeError

__all__ = ["BACKENDS", "cache_dir", "compiled_paths", "build_library"]

BACKENDS = ("numpy", "c")
_NAME = "gfmon"
_LOADED: dict[Any, Any] = {}  # library path -> loaded library (one per process)


def build_library(header: str, source: str, flags: tuple[str, ...] = ()) -> Path:
    """Compile ``gfmon.h`` / ``gfmon.c`` texts into a shared library, cached by hash.

    Parameters
    ----------
    header, source : str
        The texts of :func:`geomfdi.deployment.codegen._c_text.c_source` (prefix ``gfmon``).
    flags : tuple of str
        More compiler flags (include folders).

    Returns
    -------
    Path
        The library ``gfmon_<hash>.so`` in :func:`cache_dir` (built only when missing;
        see :func:`geomfdi._cbuild.build_library`).

    Raises
    ------
    GeomFDIError
        No C compiler, or the compiler failed (its message attached).
    """
    files = {f"{_NAME}.h": header, f"{_NAME}.c": source}
    return _build(_NAME, files, f"{_NAME}.c", flags)


#: Appended to the generated source for Python: ``y`` and ``u`` from one buffer, the
#: confirmed alarms as bytes (read as a bool array without a conversion).
_SHIM = """
int gfmon_py_step(gfmon_state *s, const double *z, double *r, unsigned char *a)
{
    int al[GFMON_NR > 0 ? GFMON_NR : 1], i, iso;
    iso = gfmon_step(s, z, z + GFMON_NY, r, al);
    for (i = 0; i < GFMON_NR; ++i) a[i] = (unsigned char)(al[i] != 0);
    return iso;
}
"""
_CDEF = """
void gfmon_init(void *s);
int gfmon_py_step(void *s, const double *z, double *r, unsigned char *a);
void gfmon_run(void *s, long n, const double *Y, const double *U, double *R, int *A, int *I);
unsigned long gfmon_state_size(void);
"""
#: Put before the generated source when Python's and numpy's headers are found: one
#: call takes ``y`` and ``u`` (float64 vectors, else ``None`` is returned and the
#: caller converts them) and returns the :class:`MonitorStep` built in C.
_PY_HEAD = """#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#include <string.h>
#undef I /* complex.h's, from numpy: the generated code names an argument I */
"""
_PY_SHIM = """
int gfmon_py_init(void)
{
    if (_import_array() < 0) {
        PyErr_Clear();
        return -1;
    }
    return 0;
}

static int gfmon_py_get(PyObject *o, double *dst, Py_ssize_t n)
{
    Py_buffer v;
    Py_ssize_t i;
    int ok;
    if (PyArray_Check(o)) { /* read in place: no buffer export (its format string) */
        PyArrayObject *arr = (PyArrayObject *)o;
        const char *p = PyArray_BYTES(arr);
        npy_intp st;
        if (PyArray_NDIM(arr) != 1 || PyArray_DIM(arr, 0) != n
            || PyArray_TYPE(arr) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(arr))
            return 0;
        st = PyArray_STRIDE(arr, 0);
        for (i = 0; i < n; ++i) /* strided: a column of a (q, L) record */
            memcpy(dst + i, p + i * st, sizeof(double));
        return 1;
    }
    if (PyObject_GetBuffer(o, &v, PyBUF_RECORDS_RO) != 0) {
        PyErr_Clear();
        return 0;
    }
    ok = v.ndim == 1 && v.shape[0] == n && v.itemsize == (Py_ssize_t)sizeof(double)
         && v.format != NULL && strcmp(v.format, "d") == 0;
    if (ok)
        for (i = 0; i < n; ++i) /* strided: a column of a (q, L) record */
            memcpy(dst + i, (const char *)v.buf + i * v.strides[0], sizeof(double));
    PyBuffer_Release(&v);
    return ok;
}

/* bound: (state address, MonitorStep type, isolation flag, state buffer kept alive) */
static PyObject *gfmon_py_fast(PyObject *bound, PyObject *const *args, Py_ssize_t nargs)
{
    double z[GFMON_NY + GFMON_NU + 1], r[GFMON_NR + 1];
    int al[GFMON_NR + 1], dec, i;
    npy_intp nr = GFMON_NR;
    PyObject *res, *alarms, *iso, *out, *u;
    PyTypeObject *type = (PyTypeObject *)PyTuple_GET_ITEM(bound, 1);
    gfmon_state *s = (gfmon_state *)PyLong_AsVoidPtr(PyTuple_GET_ITEM(bound, 0));
    npy_bool *a;
    if (s == NULL || nargs < 1 || nargs > 2) Py_RETURN_NONE;
    u = nargs == 2 ? args[1] : Py_None;
    if (!gfmon_py_get(args[0], z, GFMON_NY)) Py_RETURN_NONE;
    if (GFMON_NU && (u == Py_None || !gfmon_py_get(u, z + GFMON_NY, GFMON_NU))) Py_RETURN_NONE;
    dec = gfmon_step(s, z, z + GFMON_NY, r, al);
    res = PyArray_SimpleNew(1, &nr, NPY_DOUBLE);
    alarms = PyArray_SimpleNew(1, &nr, NPY_BOOL);
    if (PyObject_IsTrue(PyTuple_GET_ITEM(bound, 2)))
        iso = PyLong_FromLong(dec);
    else {
        Py_INCREF(Py_None);
        iso = Py_None;
    }
    out = type->tp_alloc(type, 3);
    if (res == NULL || alarms == NULL || iso == NULL || out == NULL) {
        Py_XDECREF(res);
        Py_XDECREF(alarms);
        Py_XDECREF(iso);
        Py_XDECREF(out);
        return NULL;
    }
    memcpy(PyArray_DATA((PyArrayObject *)res), r, sizeof(double) * GFMON_NR);
    a = (npy_bool *)PyArray_DATA((PyArrayObject *)alarms);
    for (i = 0; i < GFMON_NR; ++i) a[i] = (npy_bool)(al[i] != 0);
    PyTuple_SET_ITEM(out, 0, res);
    PyTuple_SET_ITEM(out, 1, alarms);
    PyTuple_SET_ITEM(out, 2, iso);
    return out;
}

static PyMethodDef gfmon_py_def = {
    "gfmon_step", (PyCFunction)(void (*)(void))gfmon_py_fast, METH_FASTCALL,
    "step(y, u): MonitorStep, or None when y or u is not a float64 vector"};

/* a builtin function running the step of the state in bound */
PyObject *gfmon_py_function(PyObject *bound)
{
    return PyCFunction_New(&gfmon_py_def, bound);
}
"""
_FFI: Any = None
#: How :meth:`Monitor.step` calls the C step: ``"python"`` (a builtin function made by
#: the compiled library through Python's and numpy's C interface: float64 vectors read
#: and the :class:`MonitorStep` built in C; the fastest, when their headers are found,
#: else ``"ctypes"``), ``"ctypes"`` (prepared pointer objects on preallocated buffers,
#: no argument conversion) or ``"cffi"`` (ABI mode on buffers bound once; needs cffi).
STEP_CALLS = "python"


def _load(path: Path) -> ctypes.CDLL:
    key = str(path)
    if key not in _LOADED:
        dll = ctypes.CDLL(key)
        vp = ctypes.c_void_p
        dll.gfmon_init.argtypes, dll.gfmon_init.restype = [vp], None
        dll.gfmon_py_step.argtypes = [vp, vp, vp, vp]
        dll.gfmon_py_step.restype = ctypes.c_int
        dll.gfmon_run.argtypes = [vp, ctypes.c_long, vp, vp, vp, vp, vp]
        dll.gfmon_run.restype = None
        dll.gfmon_state_size.argtypes, dll.gfmon_state_size.restype = [], ctypes.c_ulong
        _LOADED[key] = dll
    return _LOADED[key]


def _cffi_step(path: Path, state: Any, bufs: tuple[np.ndarray, ...]) -> Any:
    """``gfmon_py_step`` bound to ``state`` and ``bufs`` through cffi (ABI mode), or
    ``None`` without cffi: a call then costs a fraction of a ctypes call."""
    global _FFI
    try:
        import cffi
    except ImportError:  # pragma: no cover - cffi is optional
        return None
    if _FFI is None:
        _FFI = cffi.FFI()
        _FFI.cdef(_CDEF)
    key = ("cffi", str(path))
    if key not in _LOADED:
        _LOADED[key] = _FFI.dlopen(str(path))  # type: ignore[index]
    lib = _LOADED[key]  # type: ignore[index]
    kinds = {np.dtype(float): "double[]", np.dtype(np.uint8): "unsigned char[]"}
    args = (
        _FFI.cast("void *", ctypes.addressof(state)),
        *(_FFI.from_buffer(kinds[b.dtype], b) for b in bufs),
    )
    return partial(lib.gfmon_py_step, *args)


def _build_py(header: str, source: str) -> tuple[Path, Any]:
    """The library with the Python-object step ``gfmon_py_call`` (and that function
    bound through :class:`ctypes.PyDLL`) when Python's and numpy's headers compile it,
    else the plain library and ``None``."""
    import sysconfig

    inc = [sysconfig.get_paths().get("include", ""), np.get_include()]
    if STEP_CALLS == "python" and all(Path(d).is_dir() for d in inc):
        try:
            built_for = f"/* Python {sys.version.split()[0]}, numpy {np.__version__} */\n"
            path = build_library(
                header,
                built_for + _PY_HEAD + source + _SHIM + _PY_SHIM,
                tuple(f"-I{d}" for d in inc),
            )
            key = ("py", str(path))
            if key not in _LOADED:
                pydll = ctypes.PyDLL(str(path))
                if pydll.gfmon_py_init() != 0:
                    raise OSError("numpy's C interface did not load")
                fn = pydll.gfmon_py_function
                fn.argtypes, fn.restype = [ctypes.py_object], ctypes.py_object
                _LOADED[key] = fn
            return path, _LOADED[key]
        except (GeomFDIError, OSError, AttributeError):
            pass  # the plain library below
    return build_library(header, source + _SHIM), None


def compiled_paths(monitor: Any) -> tuple[Any, Any] | None:
    """``(step, feed)`` of ``monitor`` running its generated C code, or ``None``.

    ``None`` (with a :class:`RuntimeWarning` saying why) when the bank is continuous
    (the generated code is for discrete banks) or no C compiler works; the caller then
    keeps the numpy path.  The returned functions keep their own C state, started as
    ``monitor.reset()`` starts the numpy one; they return the same
    :class:`~geomfdi.deployment.online.MonitorStep` / ``MonitorOutput`` as the numpy
    path, the decisions equal (the residuals to rounding: the C loops sum in another
    order).
    """
    from geomfdi.deployment.codegen._c_text import c_source
    from geomfdi.deployment.codegen._spec import monitor_spec

    if monitor.bank.dt <= 0:
        warnings.warn(
            "backend='c': the generated code needs a discrete bank (build the monitor on "
            "bank.discretize(dt)); using the numpy path",
            RuntimeWarning,
            stacklevel=3,
        )
        return None
    try:
        header, source = c_source(monitor_spec(monitor), _NAME)
        path, pycall = _build_py(header, source)
        dll = _load(path)
    except (GeomFDIError, OSError) as exc:
        warnings.warn(f"{exc}; using the numpy path", BackendFallbackWarning, stacklevel=3)
        return None
    return _bind(dll, path, pycall, monitor)


def _bind(dll: ctypes.CDLL, path: Path, pycall: Any, monitor: Any) -> tuple[Any, Any]:
    from geomfdi.deployment.online import MonitorOutput, MonitorStep, chunks

    prog = monitor.program
    q, m, rows = prog.q, prog.m, prog.n_rows
    state = ctypes.create_string_buffer(int(dll.gfmon_state_size()))
    sp = ctypes.cast(state, ctypes.c_void_p)
    dll.gfmon_init(sp)
    # preallocated buffers, the C step bound to them once: a call converts no argument
    zbuf = np.zeros(max(q + m, 1))
    ybuf, ubuf = zbuf[:q], zbuf[q : q + m]
    rbuf = np.zeros(max(rows, 1))
    abuf = np.zeros(max(rows, 1), dtype=np.uint8)
    rview, aview = rbuf[:rows], abuf[:rows].view(bool)
    call = _cffi_step(path, state, (zbuf, rbuf, abuf)) if STEP_CALLS == "cffi" else None
    if call is None:
        ptrs = (sp, *(ctypes.c_void_p(b.ctypes.data) for b in (zbuf, rbuf, abuf)))
        c_step = dll["gfmon_py_step"]  # its own function object, without argtypes
        c_step.restype = ctypes.c_int
        call = partial(c_step, *ptrs)
    new = tuple.__new__  # MonitorStep without its Python-level __new__

    c_run = dll.gfmon_run
    isolation = monitor.isolation
    thr = monitor.thresholds
    thr_col = None if thr is None else np.where(np.isfinite(thr), thr, np.inf)[:, None]

    def convert_step(y: Any, u: Any) -> MonitorStep:
        try:
            ybuf[...] = y
            if m:
                if u is None:
                    raise ShapeError(f"u: the bank reads {m} inputs; pass u", argument="u")
                ubuf[...] = u
        except (ValueError, TypeError) as exc:
            if isinstance(exc, ShapeError):
                raise
            raise ShapeError(
                f"y, u: expected {q} outputs and {m} inputs ({exc})", argument="y"
            ) from exc
        iso = call()
        return new(MonitorStep, (rview.copy(), aview.copy(), iso if isolation else None))

    if pycall is None:
        step = convert_step
    else:
        fast = pycall((ctypes.addressof(state), MonitorStep, bool(isolation), state))

        def step(y: Any, u: Any = None) -> MonitorStep:
            out = fast(y, u)  # None: y or u to convert
            return convert_step(y, u) if out is None else out

        step.fast = fast  # type: ignore[attr-defined]  # Monitor.step calls it first

    def feed(Y: Any, U: Any = None) -> MonitorOutput:
        Y, U = chunks(Y, U, q, m)
        L = Y.shape[1]
        Yt = np.ascontiguousarray(Y.T, dtype=float)
        Ut = np.ascontiguousarray(U.T, dtype=float) if m else np.zeros((L, 1))
        R = np.empty((L, max(rows, 1)))
        A = np.empty((L, max(rows, 1)), dtype=np.intc)
        iso = np.empty(max(L, 1), dtype=np.intc)
        if L:
            c_run(
                sp, L, Yt.ctypes.data, Ut.ctypes.data, R.ctypes.data, A.ctypes.data, iso.ctypes.data
            )
        res = R[:, :rows].T  # (rows, L) views of the sample-major C arrays
        with np.errstate(invalid="ignore"):
            raw = np.zeros(res.shape, dtype=bool) if thr_col is None else np.abs(res) > thr_col
        masked = ~(np.isfinite(Y).all(axis=0) & np.isfinite(U).all(axis=0))
        alarms = A[:, :rows].T != 0
        isolated = iso[:L].astype(np.int64) if isolation else None
        return MonitorOutput(res, raw, alarms, isolated, masked)

    step.state_buffer = feed.state_buffer = state  # type: ignore[attr-defined]  # kept alive
    return step, feed
