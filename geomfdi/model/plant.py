"""The plant model: ``x' = A x + B u + Bd d + Bw w``, ``y = C x + D u + Dd d + Dw w``.

The model of Hou, Wen & Chen (2011), §2, with the disturbance and feedthrough terms, the
noise inputs ``w`` of Varga (2017), §2.2 (attenuated, not decoupled; see the user guide,
*Theory: approximate synthesis*, ``docs/theory/approximate-synthesis.md``), signal names and
an operating point (user guide, *Physical plants*, ``docs/guide/physical-plants.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._validation import as_int, as_matrix
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = ["Plant"]


def _as_dt(dt: Any) -> float:
    if isinstance(dt, bool | str | bytes) or dt is None:
        raise GeomFDIError(
            f"dt: must be 0 (continuous time) or a positive sampling period, got {dt!r}",
            argument="dt",
        )
    try:
        value = float(dt)
    except (TypeError, ValueError, OverflowError) as exc:
        raise GeomFDIError(f"dt: must be a number, got {dt!r}", argument="dt") from exc
    if not np.isfinite(value) or value < 0:
        raise GeomFDIError(
            f"dt: must be 0 (continuous time) or a positive sampling period, got {dt!r}",
            argument="dt",
        )
    return value


class Plant:
    """A linear time-invariant plant with known inputs, disturbances and noise inputs.

    Continuous time (``dt = 0``)::

        x' = A x + B u + Bd d + Bw w,      y = C x + D u + Dd d + Dw w

    or discrete time (``dt > 0``, python-control convention)::

        x[k+1] = A x[k] + B u[k] + Bd d[k] + Bw w[k],   y[k] = C x[k] + D u[k] + Dd d[k] + Dw w[k]

    Disturbances ``d`` are always decoupled exactly by the residual generators, never
    diagnosed.  Noise inputs ``w`` are not decoupled: their effect on a residual is
    attenuated and measured by the H∞ norm ``‖R_w‖∞`` (:func:`geomfdi.fault_to_noise_gap`).

    Parameters
    ----------
    A : array_like, (n, n)
        ``np.zeros((0, 0))`` for a static plant (n = 0, ``C`` of shape (q, 0)), accepted by
        the structure analyses (:func:`~geomfdi.achievable_structures`).
    B : array_like, (n, m) or None
        ``None`` means no known input (``m = 0``).
    C : array_like, (q, n)
    D : array_like, (q, m), optional
        Feedthrough; zero by default.
    Bd, Dd : array_like, optional
        Disturbance channels, (n, nd) and (q, nd).  Either may be omitted (zero).
    Bw, Dw : array_like, optional
        Noise-input channels, (n, nw) and (q, nw) (Varga 2017, §2.2: the noise inputs of
        the approximate problems).  Either may be omitted (zero); none by default
        (``nw = 0``).
    dt : float
        0 for continuous time, the sampling period for discrete time.  Positional as the
        5th argument, as in python-control's ``ss(A, B, C, D, dt)``.  A scalar 4th
        argument is ``D`` (as in python-control): 0 means no feedthrough, another scalar
        is accepted only for one output and one input; otherwise a :class:`ShapeError`
        naming ``D`` explains that the sampling period is written ``dt=``.

    inputs, outputs, states, disturbances, noise : sequence of str, optional
        Signal names (as python-control's ``inputs=``, ...; defaults ``u0, u1, ...``,
        ``y0, ...``, ``x0, ...``, ``d0, ...``, ``w0, ...``).  Faults, reports, recorded-data
        columns, the Monitor and generated code use them.
    x_op, u_op, y_op : array_like, optional
        The operating point the linear model is taken at (zero by default): the model
        holds for ``x - x_op``, ``u - u_op``, ``y - y_op``.  Recorded data, ``gf.evaluate``,
        the Monitor and generated code then take physical values and subtract
        ``u_op, y_op``; sensor gain faults scale the physical reading ``y_op + y``.

    Notes
    -----
    **python-control systems.**  A ``StateSpace`` may be given in place of ``A``
    (``gf.Plant(sys)``): its matrices, sampling period and signal names are taken (all
    inputs known; see :meth:`from_statespace` for disturbances and noise inputs).  A
    nonlinear system is linearised by :meth:`linearize`.

    **Parametric plants.**  Entries may be sympy expressions in symbols
    (``m = sympy.Symbol("m", positive=True)``): rational functions of the parameters.
    The matrices are then kept as sympy matrices (floats read through their shortest
    decimal), :attr:`parameters` lists the symbols,
    and :meth:`subs` gives the numeric plant at a point.  Only the exact design
    (``design_bank(..., exact=True)``), :func:`~geomfdi.verify_symbolic` and
    :mod:`geomfdi.exact` accept a parametric plant; every numeric function asks for
    :meth:`subs` first.  See the user guide, *Theory: verification*
    (``docs/theory/verification.md``).

    Examples
    --------
    >>> import geomfdi as gf
    >>> p = gf.Plant([[0, 1], [-2, -3]], [[0], [1]], [[1, 0]])
    >>> (p.n, p.m, p.q, p.nd, p.is_discrete)
    (2, 1, 1, 0, False)
    """

    def __init__(
        self,
        A: Any,
        B: Any = None,
        C: Any = None,
        D: Any = None,
        dt: float = 0,
        *,
        Bd: Any = None,
        Dd: Any = None,
        Bw: Any = None,
        Dw: Any = None,
        inputs: Any = None,
        outputs: Any = None,
        states: Any = None,
        disturbances: Any = None,
        noise: Any = None,
        x_op: Any = None,
        u_op: Any = None,
        y_op: Any = None,
    ) -> None:
        self.parameters: tuple[Any, ...] = ()
        names = {"inputs": inputs, "outputs": outputs, "states": states}
        names.update(disturbances=disturbances, noise=noise)
        if _is_statespace(A):
            if any(v is not None for v in (B, C, D, Bd, Dd, Bw, Dw)):
                raise GeomFDIError(
                    "B: give either a control.StateSpace or the matrices, not both",
                    argument="B",
                )
            A, B, C, D, Bd, Dd, Bw, Dw, dt, found = _statespace_parts(A, 0, 0)
            names = {k: v if v is not None else found.get(k) for k, v in names.items()}
        self._op = (x_op, u_op, y_op)
        self._names = names
        if _has_symbols(A, B, C, D, Bd, Dd, Bw, Dw):
            self._init_parametric(A, B, C, D, Bd, Dd, dt, Bw, Dw)
            self._init_signals()
            return
        self.A = as_matrix(A, "A", square=True, allow_empty=True)
        n = self.A.shape[0]
        if C is None:
            raise GeomFDIError("C: the output matrix is required", argument="C")
        # a static plant (n = 0, ``A = np.zeros((0, 0))``) has C of shape (q, 0)
        if n == 0 and np.shape(C)[-1:] != (0,):
            raise ShapeError(
                f"A: must not be empty when C has columns (a static plant has C of shape "
                f"(q, 0)), got A of shape {self.A.shape}",
                argument="A",
            )
        self.C = as_matrix(C, "C", cols=n, vector_as="row", allow_empty=n == 0)
        if self.C.shape[0] == 0:
            raise ShapeError(
                f"C: must have at least one row, got shape {self.C.shape}", argument="C"
            )
        q = self.C.shape[0]
        if B is None:
            self.B = np.zeros((n, 0))
        else:
            self.B = as_matrix(B, "B", rows=n, allow_empty=True, vector_as="column")
        m = self.B.shape[1]
        if D is None or _is_zero_scalar(D):
            self.D = np.zeros((q, m))
        else:
            _check_scalar_d(D, q, m)
            self.D = as_matrix(D, "D", rows=q, cols=m, allow_empty=True)
        self.Bd, self.Dd = _channel_pair(Bd, Dd, n, q, "Bd", "Dd")
        self.Bw, self.Dw = _channel_pair(Bw, Dw, n, q, "Bw", "Dw")
        self.dt = _as_dt(dt)
        for arr in (self.A, self.B, self.C, self.D, self.Bd, self.Dd, self.Bw, self.Dw):
            arr.setflags(write=False)
        self._init_signals()

    def _init_signals(self) -> None:
        """Names and operating point (``geomfdi.model.signals``), checked against sizes."""
        from geomfdi.model.signals import check_names, check_point

        given = self.__dict__.pop("_names")
        x_op, u_op, y_op = self.__dict__.pop("_op")
        #: True when names were given (python-control labels count, its defaults do not)
        self.named = any(v is not None for v in given.values())
        self.inputs = check_names(given["inputs"], self.m, "inputs")
        self.outputs = check_names(given["outputs"], self.q, "outputs")
        self.states = check_names(given["states"], self.n, "states")
        self.disturbances = check_names(given["disturbances"], self.nd, "disturbances")
        self.noise = check_names(given["noise"], self.nw, "noise")
        self.x_op = check_point(x_op, self.n, "x_op")
        self.u_op = check_point(u_op, self.m, "u_op")
        self.y_op = check_point(y_op, self.q, "y_op")

    @property
    def has_operating_point(self) -> bool:
        """True when ``u_op`` or ``y_op`` is non-zero: recorded data are physical values."""
        return bool(np.any(self.u_op != 0) or np.any(self.y_op != 0))

    def signal_info(self) -> dict[str, Any]:
        """Names and operating point as plain lists (stored in a bank's ``info``)."""
        return {
            "outputs": list(self.outputs),
            "inputs": list(self.inputs),
            "named": self.named,
            "y_op": self.y_op.tolist(),
            "u_op": self.u_op.tolist(),
            "x_op": self.x_op.tolist(),
        }

    def output_index(self, key: Any, argument: str = "sensor") -> int:
        """The index of output ``key`` (an index or a name in :attr:`outputs`)."""
        from geomfdi.model.signals import index_of

        return index_of(key, self.outputs, "output", argument)

    def input_index(self, key: Any, argument: str = "input") -> int:
        """The index of input ``key`` (an index or a name in :attr:`inputs`)."""
        from geomfdi.model.signals import index_of

        return index_of(key, self.inputs, "input", argument)

    def _init_parametric(self, A, B, C, D, Bd, Dd, dt, Bw=None, Dw=None) -> None:
        from geomfdi.geometry.parametric import as_exact_matrix

        self.A = as_exact_matrix(A, "A")
        n = self.A.rows
        if self.A.cols != n or n == 0:
            raise ShapeError(f"A: must be square, got shape {self.A.shape}", argument="A")
        if C is None:
            raise GeomFDIError("C: the output matrix is required", argument="C")
        self.C = as_exact_matrix(C, "C", cols=n, vector_as="row")
        q = self.C.rows
        self.B = as_exact_matrix(np.zeros((n, 0)) if B is None else B, "B", rows=n)
        m = self.B.cols
        if D is None or _is_zero_scalar(D):
            D = np.zeros((q, m))
        else:
            _check_scalar_d(D, q, m)
        self.D = as_exact_matrix(D, "D", rows=q, cols=m)
        self.Bd, self.Dd = _exact_channel_pair(Bd, Dd, n, q, "Bd", "Dd")
        self.Bw, self.Dw = _exact_channel_pair(Bw, Dw, n, q, "Bw", "Dw")
        self.dt = _as_dt(dt)
        syms: set[Any] = set()
        for M in (self.A, self.B, self.C, self.D, self.Bd, self.Dd, self.Bw, self.Dw):
            syms |= M.free_symbols
        self.parameters = tuple(sorted(syms, key=lambda s: s.name))

    @property
    def is_parametric(self) -> bool:
        """True when the entries hold sympy symbols (see *Parametric plants*)."""
        return bool(self.parameters)

    def subs(self, values: dict[Any, Any]) -> Plant:
        """The numeric plant at the parameter values ``values`` ({symbol or name: number}).

        Raises
        ------
        GeomFDIError
            Naming ``values`` when a parameter has no value or an entry is undefined there.
        """
        if not self.is_parametric:
            return self
        from geomfdi.generators.exact import _subs_values

        vals = _subs_values(self.parameters, values)
        out = []
        for name in ("A", "B", "C", "D", "Bd", "Dd", "Bw", "Dw"):
            M = getattr(self, name)
            X = M.subs(vals) if M.rows and M.cols else M
            if any(not x.is_finite for x in X):
                raise GeomFDIError(f"values: {name} is undefined at {values}", argument="values")
            out.append(np.array(X.evalf(30).tolist(), dtype=float).reshape(M.shape))
        A, B, C, D, Bd, Dd, Bw, Dw = out
        return Plant(A, B, C, D, self.dt, Bd=Bd, Dd=Dd, Bw=Bw, Dw=Dw, **self._signal_kwargs())

    def _signal_kwargs(self) -> dict[str, Any]:
        names = ("inputs", "outputs", "states", "disturbances", "noise")
        kw: dict[str, Any] = {k: getattr(self, k) for k in names} if self.named else {}
        return {**kw, "x_op": self.x_op, "u_op": self.u_op, "y_op": self.y_op}

    # ------------------------------------------------------------------ sizes
    @property
    def n(self) -> int:
        """Number of states."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of known inputs."""
        return self.B.shape[1]

    @property
    def q(self) -> int:
        """Number of outputs (sensors)."""
        return self.C.shape[0]

    @property
    def nd(self) -> int:
        """Number of disturbance inputs."""
        return self.Bd.shape[1]

    @property
    def nw(self) -> int:
        """Number of noise inputs (attenuated, not decoupled)."""
        return self.Bw.shape[1]

    @property
    def is_discrete(self) -> bool:
        """True for a discrete-time plant (``dt > 0``)."""
        return self.dt > 0

    # ------------------------------------------------------------ conversion
    @classmethod
    def from_statespace(
        cls, sys: Any, *, n_disturbances: int = 0, n_noise: int = 0, **signals: Any
    ) -> Plant:
        """Build a plant from a python-control ``StateSpace``, keeping its signal names.

        Parameters
        ----------
        sys : control.StateSpace
            Its inputs are ``[u; d; w]``.
        n_disturbances : int
            How many inputs before the noise inputs are disturbances (default 0).
        n_noise : int
            How many of the *last* inputs are noise inputs ``w`` (default 0).
        **signals
            ``inputs``, ``outputs``, ``states``, ``disturbances``, ``noise`` (names replacing
            the system's labels) and ``x_op``, ``u_op``, ``y_op`` (the operating point).
        """
        A, B, C, D, Bd, Dd, Bw, Dw, dt, found = _statespace_parts(sys, n_disturbances, n_noise)
        kw = {**found, **{k: v for k, v in signals.items() if v is not None}}
        return cls(A, B, C, D, dt, Bd=Bd, Dd=Dd, Bw=Bw, Dw=Dw, **kw)

    @classmethod
    def linearize(
        cls,
        sys: Any,
        x_op: Any,
        u_op: Any = None,
        *,
        n_disturbances: int = 0,
        n_noise: int = 0,
        params: dict[str, Any] | None = None,
        **signals: Any,
    ) -> Plant:
        """The plant linearised at an operating point of a python-control nonlinear system.

        ``A = ∂f/∂x``, ``B = ∂f/∂u``, ``C = ∂h/∂x``, ``D = ∂h/∂u`` at ``(x_op, u_op)``
        by :meth:`control.NonlinearIOSystem.linearize` (central differences), names copied
        from the system, and ``y_op = h(x_op, u_op)``.  The linear model holds for the
        deviations ``x - x_op``, ``u - u_op``, ``y - y_op``; the operating point is
        usually an equilibrium (``f(x_op, u_op) = 0``), which is not required.

        Parameters
        ----------
        sys : control.NonlinearIOSystem
            Inputs ``[u; d; w]`` (the last ``n_noise`` are noise inputs, the
            ``n_disturbances`` before them disturbances).
        x_op : array_like (n,)
        u_op : array_like (m + nd + nw,), optional
            Zero by default.  Only the known inputs' part is kept as :attr:`u_op`.
        n_disturbances, n_noise : int
            As in :meth:`from_statespace`.
        params : dict, optional
            Parameters passed to the system's functions.
        **signals
            Names replacing the system's (as in :meth:`from_statespace`).

        Examples
        --------
        >>> import control, numpy as np, geomfdi as gf
        >>> tank = control.nlsys(lambda t, x, u, p: u - np.sqrt(x), lambda t, x, u, p: x,
        ...                      inputs=["Q"], outputs=["level"], states=["h"])
        >>> p = gf.Plant.linearize(tank, [4.0], [2.0])
        >>> p.A.round(3).tolist(), p.outputs, p.y_op.tolist()
        ([[-0.25]], ('level',), [4.0])
        """
        import control

        if not isinstance(sys, control.NonlinearIOSystem):
            raise GeomFDIError(
                f"sys: expected a control.NonlinearIOSystem, got {type(sys).__name__}",
                argument="sys",
            )
        x = np.asarray(x_op, dtype=float).reshape(-1)
        if x.size != sys.nstates:
            raise ShapeError(f"x_op: expected {sys.nstates} values, got {x.size}", argument="x_op")
        u = np.zeros(sys.ninputs) if u_op is None else np.asarray(u_op, dtype=float).reshape(-1)
        if u.size != sys.ninputs:
            raise ShapeError(f"u_op: expected {sys.ninputs} values, got {u.size}", argument="u_op")
        lin = sys.linearize(x, u, params=params, copy_names=True)
        y = np.asarray(sys.output(0.0, x, u, params=params), dtype=float).reshape(-1)
        A, B, C, D, Bd, Dd, Bw, Dw, dt, found = _statespace_parts(lin, n_disturbances, n_noise)
        kw = {**found, **{k: v for k, v in signals.items() if v is not None}}
        op = {"x_op": x, "u_op": u[: B.shape[1]], "y_op": y}
        return cls(A, B, C, D, dt, Bd=Bd, Dd=Dd, Bw=Bw, Dw=Dw, **op, **kw)

    def to_statespace(self) -> Any:
        """The plant as a python-control ``StateSpace`` with inputs ``[u; d; w]``."""
        import control

        _require_numeric(self, "plant")
        B = np.hstack([self.B, self.Bd, self.Bw])
        D = np.hstack([self.D, self.Dd, self.Dw])
        if self.named:
            names_in = [*self.inputs, *self.disturbances, *self.noise]
            outs, sts = list(self.outputs), list(self.states)
        else:
            names_in = (
                [f"u[{i}]" for i in range(self.m)]
                + [f"d[{i}]" for i in range(self.nd)]
                + [f"w[{i}]" for i in range(self.nw)]
            )
            outs, sts = [f"y[{i}]" for i in range(self.q)], [f"x[{i}]" for i in range(self.n)]
        return control.ss(
            np.array(self.A),
            B,
            np.array(self.C),
            D,
            self.dt,
            inputs=names_in or None,
            outputs=outs,
            states=sts,
        )

    def __repr__(self) -> str:
        kind = f"dt={self.dt:g}" if self.is_discrete else "continuous"
        par = f", parameters={list(self.parameters)}" if self.parameters else ""
        nw = f", nw={self.nw}" if self.nw else ""
        return f"Plant(n={self.n}, m={self.m}, q={self.q}, nd={self.nd}{nw}, {kind}{par})"


def _channel_pair(
    Bx: Any, Dx: Any, n: int, q: int, bname: str, dname: str
) -> tuple[np.ndarray, np.ndarray]:
    """An input channel ``(Bx (n, k), Dx (q, k))``; an omitted half is zero of the other's width."""
    k = 0
    if Bx is not None:
        Bx = as_matrix(Bx, bname, rows=n, allow_empty=True, vector_as="column")
        k = Bx.shape[1]
    if Dx is not None:
        Dx = as_matrix(Dx, dname, rows=q, allow_empty=True, vector_as="column")
        if Bx is not None and Dx.shape[1] != k:
            raise ShapeError(
                f"{dname}: expected {k} columns (as many as {bname}), got shape {Dx.shape}",
                argument=dname,
            )
        k = Dx.shape[1]
    return (
        Bx if Bx is not None else np.zeros((n, k)),
        Dx if Dx is not None else np.zeros((q, k)),
    )


def _exact_channel_pair(Bx: Any, Dx: Any, n: int, q: int, bname: str, dname: str) -> tuple:
    """:func:`_channel_pair` for a parametric plant (sympy matrices)."""
    from geomfdi.geometry.parametric import as_exact_matrix

    Bm = None if Bx is None else as_exact_matrix(Bx, bname, rows=n)
    Dm = None if Dx is None else as_exact_matrix(Dx, dname, rows=q)
    k = 0 if Bm is None and Dm is None else (Bm if Bm is not None else Dm).cols
    if Bm is None:
        Bm = as_exact_matrix(np.zeros((n, k)), bname, rows=n, cols=k)
    if Dm is None:
        Dm = as_exact_matrix(np.zeros((q, k)), dname, rows=q, cols=k)
    if Dm.cols != Bm.cols:
        raise ShapeError(
            f"{dname}: expected {Bm.cols} columns (as many as {bname}), got shape {Dm.shape}",
            argument=dname,
        )
    return Bm, Dm


def _is_statespace(obj: Any) -> bool:
    if type(obj).__module__.split(".")[0] != "control":
        return False
    import control

    return isinstance(obj, control.StateSpace)


def _statespace_parts(sys: Any, n_disturbances: Any, n_noise: Any) -> tuple[Any, ...]:
    """``A, B, C, D, Bd, Dd, Bw, Dw, dt`` and the signal names of a python-control system
    with inputs ``[u; d; w]`` (the last ``n_noise`` noise inputs, the ``n_disturbances``
    before them disturbances)."""
    import control

    from geomfdi.model.signals import python_control_names

    if not isinstance(sys, control.StateSpace):
        raise GeomFDIError(
            f"sys: expected a control.StateSpace, got {type(sys).__name__}", argument="sys"
        )
    dt = sys.dt
    if dt is None:
        dt = 0
    if dt is True:
        raise GeomFDIError(
            "sys: discrete-time system with unspecified sampling period (dt=True); "
            "give it a numeric dt",
            argument="sys",
        )
    B = np.asarray(sys.B, dtype=float)
    D = np.asarray(sys.D, dtype=float)
    kw = as_int(n_noise, "n_noise", minimum=0)
    if kw > B.shape[1]:
        raise GeomFDIError(
            f"n_noise: must be in 0..{B.shape[1]}, got {n_noise}", argument="n_noise"
        )
    k = as_int(n_disturbances, "n_disturbances", minimum=0)
    if k > B.shape[1] - kw:
        raise GeomFDIError(
            f"n_disturbances: must be in 0..{B.shape[1] - kw}, got {n_disturbances}",
            argument="n_disturbances",
        )
    mu, md = B.shape[1] - k - kw, B.shape[1] - kw
    labels_in = python_control_names(sys.input_labels, "inputs")
    found = {
        "inputs": None if labels_in is None else labels_in[:mu],
        "disturbances": None if labels_in is None or not k else labels_in[mu:md],
        "noise": None if labels_in is None or not kw else labels_in[md:],
        "outputs": python_control_names(sys.output_labels, "outputs"),
        "states": python_control_names(sys.state_labels, "states"),
    }
    found = {key: v for key, v in found.items() if v is not None}
    return (
        np.asarray(sys.A, dtype=float),
        B[:, :mu],
        np.asarray(sys.C, dtype=float),
        D[:, :mu],
        B[:, mu:md] if k else None,
        D[:, mu:md] if k else None,
        B[:, md:] if kw else None,
        D[:, md:] if kw else None,
        dt,
        found,
    )


def _has_symbols(*values: Any) -> bool:
    """True when a value holds sympy objects with free symbols (sympy imported lazily)."""
    for v in values:
        if v is None:
            continue
        mod = type(v).__module__.split(".")[0]
        if mod == "sympy" or (
            isinstance(v, list | tuple | np.ndarray)
            and any(
                type(x).__module__.split(".")[0] == "sympy"
                for x in np.ravel(np.array(v, dtype=object))
            )
        ):
            from geomfdi.geometry.parametric import has_symbols

            if has_symbols(v):
                return True
    return False


def _is_scalar(D: Any) -> bool:
    try:
        return np.ndim(D) == 0
    except ValueError:  # ragged nesting: not a scalar (as_matrix names the error)
        return False


def _is_zero_scalar(D: Any) -> bool:
    return _is_scalar(D) and not isinstance(D, bool | str | bytes) and _scalar(D) == 0


def _scalar(D: Any) -> Any:
    try:
        return complex(D)
    except (TypeError, ValueError, OverflowError):
        return None


def _check_scalar_d(D: Any, q: int, m: int) -> None:
    """A non-zero scalar D is only D for one output and one input (python-control's rule)."""
    if _is_scalar(D) and not isinstance(D, bool | str | bytes) and (q, m) != (1, 1):
        raise ShapeError(
            f"D: got the scalar {D!r}, but D must be a ({q}, {m}) matrix for this plant. "
            "The 4th positional argument is the feedthrough D, as in python-control's "
            f"ss(A, B, C, D, dt); for a sampling period write Plant(A, B, C, dt={D!r}) or "
            f"Plant(A, B, C, 0, {D!r})",
            argument="D",
        )


def _require_numeric(plant: Plant, name: str) -> None:
    if plant.is_parametric:
        raise GeomFDIError(
            f"{name}: has symbolic parameters {list(plant.parameters)}; substitute values with "
            f"{name}.subs({{...}}) or use the exact design (design_bank(..., exact=True)) and "
            "verify_symbolic",
            argument=name,
        )


def _require_states(plant: Plant, name: str, static: bool) -> Plant:
    if plant.n == 0 and not static:
        raise GeomFDIError(
            f"{name}: a static plant (n = 0) is accepted by the structure analyses "
            "(achievable_structures, structure_orders, isolability_analysis) only",
            argument=name,
        )
    return plant


def as_plant(
    plant: Any, name: str = "plant", *, parametric: bool = False, static: bool = False
) -> Plant:
    """Return ``plant`` as a :class:`Plant`; a python-control ``StateSpace`` is converted.

    Every public function that takes a plant accepts either form (the ``StateSpace`` inputs
    are all taken as control inputs; use :meth:`Plant.from_statespace` with
    ``n_disturbances`` to mark trailing inputs as disturbances).

    ``parametric=True`` also accepts a plant with symbolic parameters (for the exact
    functions); otherwise such a plant is refused with a message asking for ``subs``.
    ``static=True`` also accepts a static plant (n = 0; the structure analyses such as
    :func:`~geomfdi.achievable_structures`); otherwise it is refused.

    Raises
    ------
    GeomFDIError
        Naming ``name`` when ``plant`` is neither (or is parametric where numbers are needed,
        or static where states are needed).
    """
    if isinstance(plant, Plant):
        if not parametric:
            _require_numeric(plant, name)
        return _require_states(plant, name, static)
    if type(plant).__module__.split(".")[0] == "control":
        import control

        if isinstance(plant, control.StateSpace):
            return _require_states(Plant.from_statespace(plant), name, static)
    raise GeomFDIError(
        f"{name}: expected a gf.Plant or control.StateSpace, got {type(plant).__name__}",
        argument=name,
    )
