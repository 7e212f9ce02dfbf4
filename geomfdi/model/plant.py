"""The plant model: ``x' = A x + B u + Bd d``, ``y = C x + D u + Dd d`` (math.md §1)."""

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
    """A linear time-invariant plant with known inputs and disturbances.

    Continuous time (``dt = 0``)::

        x' = A x + B u + Bd d,      y = C x + D u + Dd d

    or discrete time (``dt > 0``, python-control convention)::

        x[k+1] = A x[k] + B u[k] + Bd d[k],   y[k] = C x[k] + D u[k] + Dd d[k]

    Disturbances ``d`` are always decoupled by the residual generators, never diagnosed.

    Parameters
    ----------
    A : array_like, (n, n)
    B : array_like, (n, m) or None
        ``None`` means no known input (``m = 0``).
    C : array_like, (q, n)
    D : array_like, (q, m), optional
        Feedthrough; zero by default.
    Bd, Dd : array_like, optional
        Disturbance channels, (n, nd) and (q, nd).  Either may be omitted (zero).
    dt : float
        0 for continuous time, the sampling period for discrete time.

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
        *,
        Bd: Any = None,
        Dd: Any = None,
        dt: float = 0,
    ) -> None:
        self.A = as_matrix(A, "A", square=True)
        n = self.A.shape[0]
        if C is None:
            raise GeomFDIError("C: the output matrix is required", argument="C")
        self.C = as_matrix(C, "C", cols=n, vector_as="row")
        q = self.C.shape[0]
        if B is None:
            self.B = np.zeros((n, 0))
        else:
            self.B = as_matrix(B, "B", rows=n, allow_empty=True, vector_as="column")
        m = self.B.shape[1]
        if D is None:
            self.D = np.zeros((q, m))
        else:
            self.D = as_matrix(D, "D", rows=q, cols=m, allow_empty=True)
        nd = 0
        if Bd is not None:
            Bd = as_matrix(Bd, "Bd", rows=n, allow_empty=True, vector_as="column")
            nd = Bd.shape[1]
        if Dd is not None:
            Dd = as_matrix(Dd, "Dd", rows=q, allow_empty=True, vector_as="column")
            if Bd is not None and Dd.shape[1] != nd:
                raise ShapeError(
                    f"Dd: expected {nd} columns (as many as Bd), got shape {Dd.shape}",
                    argument="Dd",
                )
            nd = Dd.shape[1]
        self.Bd = Bd if Bd is not None else np.zeros((n, nd))
        self.Dd = Dd if Dd is not None else np.zeros((q, nd))
        self.dt = _as_dt(dt)
        for arr in (self.A, self.B, self.C, self.D, self.Bd, self.Dd):
            arr.setflags(write=False)

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
    def is_discrete(self) -> bool:
        """True for a discrete-time plant (``dt > 0``)."""
        return self.dt > 0

    # ------------------------------------------------------------ conversion
    @classmethod
    def from_statespace(cls, sys: Any, *, n_disturbances: int = 0) -> Plant:
        """Build a plant from a python-control ``StateSpace``.

        Parameters
        ----------
        sys : control.StateSpace
            Its inputs are ``[u; d]``.
        n_disturbances : int
            How many of the *last* inputs are disturbances (default 0).
        """
        import control

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
        k = as_int(n_disturbances, "n_disturbances", minimum=0)
        if k > B.shape[1]:
            raise GeomFDIError(
                f"n_disturbances: must be in 0..{B.shape[1]}, got {n_disturbances}",
                argument="n_disturbances",
            )
        mu = B.shape[1] - k
        return cls(
            sys.A,
            B[:, :mu],
            sys.C,
            D[:, :mu],
            Bd=B[:, mu:] if k else None,
            Dd=D[:, mu:] if k else None,
            dt=dt,
        )

    def to_statespace(self) -> Any:
        """The plant as a python-control ``StateSpace`` with inputs ``[u; d]``."""
        import control

        B = np.hstack([self.B, self.Bd])
        D = np.hstack([self.D, self.Dd])
        names_in = [f"u[{i}]" for i in range(self.m)] + [f"d[{i}]" for i in range(self.nd)]
        return control.ss(
            np.array(self.A),
            B,
            np.array(self.C),
            D,
            self.dt,
            inputs=names_in or None,
            outputs=[f"y[{i}]" for i in range(self.q)],
            states=[f"x[{i}]" for i in range(self.n)],
        )

    def __repr__(self) -> str:
        kind = f"dt={self.dt:g}" if self.is_discrete else "continuous"
        return f"Plant(n={self.n}, m={self.m}, q={self.q}, nd={self.nd}, {kind})"


def as_plant(plant: Any, name: str = "plant") -> Plant:
    """Return ``plant`` as a :class:`Plant`; a python-control ``StateSpace`` is converted.

    Every public function that takes a plant accepts either form (the ``StateSpace`` inputs
    are all taken as control inputs; use :meth:`Plant.from_statespace` with
    ``n_disturbances`` to mark trailing inputs as disturbances).

    Raises
    ------
    GeomFDIError
        Naming ``name`` when ``plant`` is neither.
    """
    if isinstance(plant, Plant):
        return plant
    if type(plant).__module__.split(".")[0] == "control":
        import control

        if isinstance(plant, control.StateSpace):
            return Plant.from_statespace(plant)
    raise GeomFDIError(
        f"{name}: expected a gf.Plant or control.StateSpace, got {type(plant).__name__}",
        argument=name,
    )
