"""Safe, vectorised expressions of time for model files (``"0.2 + sin(0.5*t)"``).

Grammar (everything else is rejected with a :class:`~geomfdi.errors.ModelFileError`
naming the entry of the model file)::

    expr  := number | t | pi | e | (expr) | +expr | -expr
           | expr op expr                      op: + - * / ** %
           | expr cmp expr [cmp expr ...]      cmp: < <= > >=   (gives 0.0 or 1.0)
           | func(expr[, expr])                func: see FUNCTIONS and ARITY

Numbers are int or float literals (no booleans, strings or complex numbers).  The text is
parsed with :mod:`ast`, checked node by node against this whitelist and evaluated by a
small tree walker over numpy arrays; it is never passed to ``eval``, so attribute access,
subscripts, lambdas, comprehensions and calls of anything but the listed numpy functions
cannot run.  An expression is limited to :data:`MAX_LENGTH` characters.
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from typing import Any

import numpy as np

from geomfdi.errors import ModelFileError

__all__ = ["compile_expression", "FUNCTIONS", "ARITY", "MAX_LENGTH"]

FUNCTIONS: dict[str, Callable[..., Any]] = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "exp": np.exp,
    "log": np.log,
    "sqrt": np.sqrt,
    "abs": np.abs,
    "tanh": np.tanh,
    "arctan": np.arctan,
    "sign": np.sign,
    "floor": np.floor,
    "minimum": np.minimum,
    "maximum": np.maximum,
    "step": lambda x: np.where(np.asarray(x) >= 0, 1.0, 0.0),
    "ramp": lambda x: np.maximum(np.asarray(x, dtype=float), 0.0),
}
"""Functions an expression may call (``step(x)``: 1 for x >= 0; ``ramp(x)``: max(x, 0))."""

ARITY: dict[str, int] = {name: 2 if name in ("minimum", "maximum") else 1 for name in FUNCTIONS}
"""Number of arguments of each function of :data:`FUNCTIONS`."""

MAX_LENGTH = 1000
"""Longest expression accepted (characters)."""

_CONSTANTS = {"pi": np.pi, "e": np.e}
_BINOPS: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: np.add,
    ast.Sub: np.subtract,
    ast.Mult: np.multiply,
    ast.Div: np.divide,
    ast.Pow: np.power,
    ast.Mod: np.mod,
}
_UNARYOPS: dict[type, Callable[[Any], Any]] = {ast.UAdd: np.positive, ast.USub: np.negative}
_CMPOPS: dict[type, Callable[[Any, Any], Any]] = {
    ast.Lt: np.less,
    ast.LtE: np.less_equal,
    ast.Gt: np.greater,
    ast.GtE: np.greater_equal,
}
_NODES = (
    ast.Expression,
    ast.BinOp,
    ast.UnaryOp,
    ast.Constant,
    ast.Name,
    ast.Call,
    ast.Load,
    ast.Compare,
    ast.operator,
    ast.unaryop,
    ast.cmpop,
)
_FUNCS = ", ".join(sorted(FUNCTIONS))
_ALLOWED = f"t, pi, e, {_FUNCS}"


def _check(node: ast.AST, where: str) -> None:
    """Reject every node outside the grammar of the module docstring."""
    for sub in ast.walk(node):
        if not isinstance(sub, _NODES):
            raise ModelFileError(
                f"{where}: unsupported syntax ({type(sub).__name__}); allowed: numbers, "
                f"{_ALLOWED}, + - * / ** % < <= > >=",
                argument=where,
            )
        if isinstance(sub, ast.Constant) and (
            isinstance(sub.value, bool) or not isinstance(sub.value, int | float)
        ):
            raise ModelFileError(
                f"{where}: only numbers are allowed, got {sub.value!r}", argument=where
            )
        if isinstance(sub, ast.Call):
            if not isinstance(sub.func, ast.Name):
                raise ModelFileError(
                    f"{where}: unsupported syntax (call of {type(sub.func).__name__}); only "
                    f"the functions {_FUNCS} can be called",
                    argument=where,
                )
            name = sub.func.id
            if name not in FUNCTIONS:
                raise ModelFileError(
                    f"{where}: unknown function {name!r} (allowed: {_FUNCS})",
                    argument=where,
                )
            if sub.keywords or len(sub.args) != ARITY[name]:
                raise ModelFileError(
                    f"{where}: {name}() takes {ARITY[name]} positional argument"
                    f"{'s' if ARITY[name] > 1 else ''}",
                    argument=where,
                )
        elif isinstance(sub, ast.Name):
            if sub.id not in _CONSTANTS and sub.id != "t" and sub.id not in FUNCTIONS:
                raise ModelFileError(
                    f"{where}: unknown name {sub.id!r} (allowed: {_ALLOWED})", argument=where
                )
        elif isinstance(sub, ast.BinOp) and type(sub.op) not in _BINOPS:
            raise ModelFileError(
                f"{where}: unsupported operator {type(sub.op).__name__}", argument=where
            )
        elif isinstance(sub, ast.UnaryOp) and type(sub.op) not in _UNARYOPS:
            raise ModelFileError(
                f"{where}: unsupported operator {type(sub.op).__name__} (only + and -)",
                argument=where,
            )
        elif isinstance(sub, ast.Compare) and any(type(o) not in _CMPOPS for o in sub.ops):
            raise ModelFileError(
                f"{where}: unsupported comparison (only < <= > >=)", argument=where
            )
    # a function name used as a value ("sin + 1") is not a number
    called = {id(c.func) for c in ast.walk(node) if isinstance(c, ast.Call)}
    for sub in ast.walk(node):
        if isinstance(sub, ast.Name) and sub.id in FUNCTIONS and id(sub) not in called:
            raise ModelFileError(
                f"{where}: {sub.id!r} is a function; call it as {sub.id}(...)", argument=where
            )


def _eval(node: ast.AST, t: np.ndarray) -> Any:
    if isinstance(node, ast.Expression):
        return _eval(node.body, t)
    if isinstance(node, ast.Constant):
        try:
            return float(node.value)
        except OverflowError:  # an integer literal beyond the float range
            return float("inf") if node.value > 0 else float("-inf")
    if isinstance(node, ast.Name):
        return t if node.id == "t" else _CONSTANTS[node.id]
    if isinstance(node, ast.UnaryOp):
        return _UNARYOPS[type(node.op)](_eval(node.operand, t))
    if isinstance(node, ast.BinOp):
        return _BINOPS[type(node.op)](_eval(node.left, t), _eval(node.right, t))
    if isinstance(node, ast.Compare):
        left = _eval(node.left, t)
        out = np.ones_like(np.asarray(t, dtype=float))
        for op, comp in zip(node.ops, node.comparators, strict=True):
            right = _eval(comp, t)
            out = out * _CMPOPS[type(op)](left, right)
            left = right
        return out.astype(float)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        return FUNCTIONS[node.func.id](*[_eval(a, t) for a in node.args])
    raise ModelFileError(f"unsupported expression node {type(node).__name__}")  # pragma: no cover


def compile_expression(text: Any, where: str) -> Callable[[np.ndarray], np.ndarray]:
    """Compile a number or an expression string of ``t`` into a vectorised function.

    Parameters
    ----------
    text : str or number
        A finite number, or an expression in the grammar of the module docstring.
    where : str
        Location in the model file (e.g. ``"simulation.u[0]"``), for error messages.

    Returns
    -------
    callable
        ``f(t)`` returning a float array of the shape of ``t``; it raises
        :class:`~geomfdi.errors.ModelFileError` when the value is not finite somewhere
        on the grid it is evaluated on (e.g. ``log(t)`` at ``t = 0``).

    Raises
    ------
    ModelFileError
        When the text is not a number or not in the grammar, naming ``where``.

    Examples
    --------
    >>> f = compile_expression("0.2 + sin(0.5*t)", "u[0]")
    >>> float(f(0.0))
    0.2
    >>> compile_expression("1 + 2*(t >= 3)", "gain")([0.0, 5.0]).tolist()
    [1.0, 3.0]
    """
    if isinstance(text, bool):
        raise ModelFileError(
            f"{where}: expected a number or an expression of t, got {text!r}", argument=where
        )
    if isinstance(text, int | float):
        try:
            value = float(text)
        except OverflowError:
            value = float("inf")
        if not np.isfinite(value):
            raise ModelFileError(f"{where}: must be finite, got {value}", argument=where)
        return lambda t: np.full(np.shape(t), value)
    if not isinstance(text, str):
        raise ModelFileError(
            f"{where}: expected a number or an expression of t, got {text!r}", argument=where
        )
    if len(text) > MAX_LENGTH:
        raise ModelFileError(
            f"{where}: expression longer than {MAX_LENGTH} characters", argument=where
        )
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
        raise ModelFileError(f"{where}: cannot parse expression {text!r}", argument=where) from exc
    _check(tree, where)

    def evaluate(t: Any) -> np.ndarray:
        tt = np.asarray(t, dtype=float)
        try:
            with np.errstate(all="ignore"):
                raw = np.asarray(_eval(tree, tt), dtype=float)
        except RecursionError as exc:
            raise ModelFileError(f"{where}: expression nested too deeply", argument=where) from exc
        return np.broadcast_to(raw, tt.shape).copy()

    def f(t: Any) -> np.ndarray:
        out = evaluate(t)
        if not np.all(np.isfinite(out)):
            bad = np.asarray(t, dtype=float).reshape(-1)[~np.isfinite(out).reshape(-1)]
            at = f" (first at t = {bad[0]:g})" if bad.size else ""
            raise ModelFileError(
                f"{where}: expression {text!r} is not finite on the time grid{at}",
                argument=where,
            )
        return out

    evaluate(np.zeros(1))  # fail early on structural problems; finiteness is checked on the grid
    return f
