"""Safe, vectorised expressions of time for model files (``"0.2 + sin(0.5*t)"``).

Only numbers, the variable ``t``, ``pi``, ``e``, the operators ``+ - * / ** %``,
comparisons (giving 0/1) and a fixed set of numpy functions are allowed; the expression
is parsed with :mod:`ast` and never passed to ``eval``.
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from typing import Any

import numpy as np

from .errors import ModelFileError

__all__ = ["compile_expression", "FUNCTIONS"]

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
_CONSTANTS = {"pi": np.pi, "e": np.e}
_BINOPS: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: np.add,
    ast.Sub: np.subtract,
    ast.Mult: np.multiply,
    ast.Div: np.divide,
    ast.Pow: np.power,
    ast.Mod: np.mod,
}
_CMPOPS: dict[type, Callable[[Any, Any], Any]] = {
    ast.Lt: np.less,
    ast.LtE: np.less_equal,
    ast.Gt: np.greater,
    ast.GtE: np.greater_equal,
}


def _check(node: ast.AST, where: str) -> None:
    for sub in ast.walk(node):
        ok = isinstance(
            sub,
            ast.Expression
            | ast.BinOp
            | ast.UnaryOp
            | ast.Constant
            | ast.Name
            | ast.Call
            | ast.Load
            | ast.Compare
            | ast.operator
            | ast.unaryop
            | ast.cmpop,
        )
        if not ok:
            raise ModelFileError(f"{where}: unsupported syntax {type(sub).__name__}")
        if isinstance(sub, ast.Constant) and not isinstance(sub.value, int | float):
            raise ModelFileError(f"{where}: only numbers are allowed, got {sub.value!r}")
        if (
            isinstance(sub, ast.Name)
            and sub.id not in FUNCTIONS
            and sub.id not in _CONSTANTS
            and sub.id != "t"
        ):
            raise ModelFileError(
                f"{where}: unknown name {sub.id!r} (allowed: t, pi, e, "
                f"{', '.join(sorted(FUNCTIONS))})"
            )
        if isinstance(sub, ast.Call) and (
            not isinstance(sub.func, ast.Name) or sub.func.id not in FUNCTIONS or sub.keywords
        ):
            raise ModelFileError(f"{where}: unsupported function call")
        if isinstance(sub, ast.BinOp) and type(sub.op) not in _BINOPS:
            raise ModelFileError(f"{where}: unsupported operator {type(sub.op).__name__}")
        if isinstance(sub, ast.Compare) and any(type(o) not in _CMPOPS for o in sub.ops):
            raise ModelFileError(f"{where}: unsupported comparison")


def _eval(node: ast.AST, t: np.ndarray) -> Any:
    if isinstance(node, ast.Expression):
        return _eval(node.body, t)
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.Name):
        return t if node.id == "t" else _CONSTANTS[node.id]
    if isinstance(node, ast.UnaryOp):
        v = _eval(node.operand, t)
        return -v if isinstance(node.op, ast.USub) else v
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
    if isinstance(node, ast.Call):
        assert isinstance(node.func, ast.Name)
        return FUNCTIONS[node.func.id](*[_eval(a, t) for a in node.args])
    raise ModelFileError(f"unsupported expression node {type(node).__name__}")  # pragma: no cover


def compile_expression(text: Any, where: str) -> Callable[[np.ndarray], np.ndarray]:
    """Compile a number or an expression string of ``t`` into a vectorised function.

    Parameters
    ----------
    text : str or number
    where : str
        Location in the model file, for error messages.

    Returns
    -------
    callable
        ``f(t)`` returning an array of the shape of ``t``.

    Examples
    --------
    >>> f = compile_expression("0.2 + sin(0.5*t)", "u[0]")
    >>> float(f(0.0))
    0.2
    """
    if isinstance(text, bool):
        raise ModelFileError(f"{where}: expected a number or an expression of t, got {text!r}")
    if isinstance(text, int | float):
        value = float(text)
        if not np.isfinite(value):
            raise ModelFileError(f"{where}: must be finite, got {value}")
        return lambda t: np.full(np.shape(t), value)
    if not isinstance(text, str):
        raise ModelFileError(f"{where}: expected a number or an expression of t, got {text!r}")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ModelFileError(f"{where}: cannot parse expression {text!r}") from exc
    _check(tree, where)

    def f(t: Any) -> np.ndarray:
        tt = np.asarray(t, dtype=float)
        with np.errstate(all="ignore"):
            out = np.broadcast_to(np.asarray(_eval(tree, tt), dtype=float), tt.shape).copy()
        if not np.all(np.isfinite(out)):
            raise ModelFileError(f"{where}: expression {text!r} is not finite on the time grid")
        return out

    f(np.zeros(1))  # fail early on obviously bad expressions
    return f
