"""Exact residual generators: matrices of rationals or rational functions of parameters.

The objects returned by ``gf.design_bank(..., exact=True)``.  They are data objects; the
numeric counterparts (:class:`~geomfdi.generators.generator.ResidualGenerator`,
:class:`~geomfdi.generators.generator.ResidualBank`) are obtained with :meth:`subs`.

See the user guide, *Theory: verification* (``docs/theory/verification.md``), section
"Parametric plants".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi.errors import DesignError, GeomFDIError
from geomfdi.generators.generator import ResidualBank, ResidualGenerator

__all__ = ["ExactResidualGenerator", "ExactResidualBank", "ExceptionalCondition"]


@dataclass(frozen=True)
class ExceptionalCondition:
    """One polynomial condition ``expr = 0`` on the parameters.

    Attributes
    ----------
    expr : sympy.Expr
        An irreducible polynomial in the parameters.
    kind : str
        ``"fails"``: on ``expr = 0`` a rank of the construction drops and the delivered
        generator, evaluated there, loses a target or a decoupling (checked exactly on
        the specialised family); ``"formula"``: a delivered entry has a pole there
        (redesign at that point); ``"candidate"``: a pivot of the elimination vanishes
        there, not checked (the condition is not linear in any parameter).
    rows : tuple of int
        Bank rows concerned.
    """

    expr: Any
    kind: str
    rows: tuple[int, ...]

    def __str__(self) -> str:
        return f"{self.expr} = 0 ({self.kind}; rows {list(self.rows)})"


def _subs_values(parameters: tuple[Any, ...], values: Any) -> dict[Any, Any]:
    import sympy as sp

    if not isinstance(values, dict):
        raise GeomFDIError(
            f"values: expected a dict {{symbol: number}}, got {type(values).__name__}",
            argument="values",
        )
    by_name = {str(s): s for s in parameters}
    out = {}
    for k, v in values.items():
        sym = by_name.get(str(k)) if not isinstance(k, sp.Symbol) or k not in parameters else k
        if sym is None:
            raise GeomFDIError(
                f"values: {k} is not a parameter (parameters: {list(parameters)})",
                argument="values",
            )
        if isinstance(v, str):  # a number literal, never evaluated
            from geomfdi.geometry.parametric import exact_scalar

            v = exact_scalar(v, "values")
        try:
            fv = float(v)
        except (TypeError, ValueError) as exc:
            raise GeomFDIError(
                f"values: {k} must be a number, got {v!r}", argument="values"
            ) from exc
        if not np.isfinite(fv):
            raise GeomFDIError(f"values: {k} must be finite, got {v!r}", argument="values")
        out[sym] = sp.Rational(repr(fv)) if isinstance(v, float) else sp.nsimplify(v)
    missing = [s for s in parameters if s not in out]
    if missing:
        raise GeomFDIError(f"values: no value for {missing}", argument="values")
    return out


def _numeric(M: Any, vals: dict[Any, Any], name: str) -> np.ndarray:
    import sympy as sp

    if M.rows == 0 or M.cols == 0:
        return np.zeros(M.shape)
    X = M.xreplace(vals) if all(v.is_Rational for v in vals.values()) else M.subs(vals)
    if X.has(sp.zoo, sp.nan, sp.oo):
        raise DesignError(
            f"values: the generator's {name} has a pole at these parameter values (they lie on "
            "its exceptional set); redesign at this point",
            argument="values",
        )
    if all(x.is_Rational for x in X):
        return np.array([[float(x) for x in X.row(i)] for i in range(X.rows)])
    return np.array(X.evalf(30).tolist(), dtype=float)


@dataclass
class ExactResidualGenerator:
    """A residual generator ``(F, E, G, M, H, K)`` with exact (sympy) matrices.

    ``w' = F w − E y + G u``, ``r = M w − H y + K u`` (as
    :class:`~geomfdi.generators.generator.ResidualGenerator`), entries rationals or
    rational functions of :attr:`parameters`.  ``info`` holds the generic dimensions
    (``S_dim``, ``S_history``, ``W_history``, ``quotient_order``), the poles and the
    conditions found for this row.
    """

    F: Any
    E: Any
    G: Any
    M: Any
    H: Any
    K: Any
    dt: float = 0.0
    target: tuple[int, ...] = ()
    decoupled: tuple[int, ...] = ()
    parameters: tuple[Any, ...] = ()
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def order(self) -> int:
        return self.F.rows

    @property
    def n_outputs(self) -> int:
        return self.M.rows

    def subs(self, values: dict[Any, Any]) -> ResidualGenerator:
        """The numeric generator at the parameter values ``values`` ({symbol or name: number})."""
        vals = _subs_values(self.parameters, values)
        mats = {k: _numeric(getattr(self, k), vals, k) for k in "FEGMHK"}
        return ResidualGenerator(
            **mats,
            dt=self.dt,
            target=self.target,
            decoupled=self.decoupled,
            method="exact",
            info={"parameters": {str(k): float(v) for k, v in vals.items()}, "exact": self},
        )

    def _repr_latex_(self) -> str:
        import sympy as sp

        blocks = ", ".join(f"{k} = {sp.latex(getattr(self, k))}" for k in "FEGMHK")
        return f"$\\displaystyle {blocks}$"

    def __repr__(self) -> str:
        return (
            f"ExactResidualGenerator(order={self.order}, outputs={self.n_outputs}, "
            f"target={list(self.target)}, decoupled={list(self.decoupled)}, "
            f"parameters={list(self.parameters)})"
        )


@dataclass
class ExactResidualBank:
    """A bank of exact residual generators, one per row of the requested structure.

    Attributes
    ----------
    generators : list of ExactResidualGenerator or None
    requested, structure : ndarray of bool
        Requested and generically achieved structure (proven over the field of rational
        functions of the parameters).
    diagnostics : list of str
    faults : list
    parameters : tuple of sympy.Symbol
    exceptional : list of ExceptionalCondition
        Where the result may not hold (see :class:`ExceptionalCondition`).
    dt : float
    info : dict
    """

    generators: list[ExactResidualGenerator | None]
    requested: np.ndarray
    structure: np.ndarray
    diagnostics: list[str]
    faults: list[Any]
    parameters: tuple[Any, ...]
    exceptional: list[ExceptionalCondition]
    dt: float = 0.0
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def present(self) -> list[int]:
        return [k for k, g in enumerate(self.generators) if g is not None]

    @property
    def isolable(self) -> np.ndarray:
        nf = self.structure.shape[1]
        cols = [tuple(self.structure[:, j]) for j in range(nf)]
        return np.array(
            [
                any(cols[j]) and all(cols[j] != cols[i] for i in range(nf) if i != j)
                for j in range(nf)
            ]
        )

    def on_exceptional_set(self, values: dict[Any, Any]) -> list[ExceptionalCondition]:
        """The conditions that vanish at ``values``."""
        vals = _subs_values(self.parameters, values)
        return [c for c in self.exceptional if c.expr.subs(vals) == 0]

    def subs(self, values: dict[Any, Any]) -> ResidualBank:
        """The numeric :class:`~geomfdi.generators.generator.ResidualBank` at ``values``.

        Raises
        ------
        DesignError
            Naming ``values`` when they lie on a confirmed exceptional condition (the
            generic design does not hold there) or a delivered matrix has a pole there.
        """
        hit = [c for c in self.on_exceptional_set(values) if c.kind in ("fails", "formula")]
        if hit:
            raise DesignError(
                "values: on the exceptional set of the design ("
                + "; ".join(str(c) for c in hit)
                + "); redesign at this point",
                argument="values",
            )
        gens = [None if g is None else g.subs(values) for g in self.generators]
        return ResidualBank(
            generators=gens,
            requested=self.requested.copy(),
            structure=self.structure.copy(),
            isolable=self.isolable,
            diagnostics=list(self.diagnostics),
            faults=list(self.faults),
            dt=self.dt,
            method="exact",
            info={**self.info, "parameters": {str(k): v for k, v in values.items()}},
        )

    def _repr_latex_(self) -> str:
        import sympy as sp

        cond = ", ".join(f"{sp.latex(c.expr)} = 0" for c in self.exceptional) or "none"
        return (
            f"Exact bank: {len(self.generators)} rows, parameters "
            f"${sp.latex(sp.Tuple(*self.parameters))}$, exceptional set: ${cond}$"
        )

    def __repr__(self) -> str:
        conds = [str(c.expr) for c in self.exceptional]
        return (
            f"ExactResidualBank(rows={len(self.generators)}, present={self.present}, "
            f"parameters={list(self.parameters)}, exceptional={conds})"
        )
