"""The safe expression evaluator of model files (geomfdi.io.expressions)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from geomfdi.errors import ModelFileError
from geomfdi.io.expressions import ARITY, FUNCTIONS, MAX_LENGTH, compile_expression

T = np.linspace(0.0, 10.0, 41)

# the documented grammar: expression -> numpy reference
ACCEPTED = {
    "0.2": lambda t: np.full_like(t, 0.2),
    "3": lambda t: np.full_like(t, 3.0),
    "t": lambda t: t,
    "-t": lambda t: -t,
    "+t": lambda t: t,
    "1 - 0.05*(t - 5)": lambda t: 1 - 0.05 * (t - 5),
    "t / 4 + t % 3": lambda t: t / 4 + t % 3,
    "2**(-t)": lambda t: 2.0 ** (-t),
    "1.5e-1 * t**2": lambda t: 0.15 * t**2,
    "pi * e": lambda t: np.full_like(t, np.pi * np.e),
    "sin(0.5*t) + cos(0.3*t)": lambda t: np.sin(0.5 * t) + np.cos(0.3 * t),
    "tan(0.1*t) + tanh(t) + arctan(t)": lambda t: np.tan(0.1 * t) + np.tanh(t) + np.arctan(t),
    "exp(-t) + log(1 + t) + sqrt(t)": lambda t: np.exp(-t) + np.log1p(t) + np.sqrt(t),
    "abs(t - 5) + sign(t - 5) + floor(t)": lambda t: np.abs(t - 5) + np.sign(t - 5) + np.floor(t),
    "minimum(t, 3) + maximum(t, 7)": lambda t: np.minimum(t, 3) + np.maximum(t, 7),
    "step(t - 8)": lambda t: (t >= 8).astype(float),
    "ramp(t - 5)": lambda t: np.maximum(t - 5, 0.0),
    "1 + 0.5*(t >= 8)": lambda t: 1 + 0.5 * (t >= 8),
    "(t > 2) * (t <= 4)": lambda t: ((t > 2) & (t <= 4)).astype(float),
    "2 < t <= 4": lambda t: ((t > 2) & (t <= 4)).astype(float),
    "t < 3": lambda t: (t < 3).astype(float),
}


@pytest.mark.parametrize("text", sorted(ACCEPTED))
def test_accepts_the_documented_grammar(text: str) -> None:
    f = compile_expression(text, "u[0]")
    out = f(T)
    assert out.shape == T.shape and out.dtype == float
    np.testing.assert_allclose(out, ACCEPTED[text](T), rtol=1e-14, atol=1e-14)


def test_every_whitelisted_function_is_callable_with_its_arity() -> None:
    for name, arity in ARITY.items():
        args = ", ".join(["(t + 1)"] * arity)
        f = compile_expression(f"{name}({args})", "x")
        expected = FUNCTIONS[name](*([T + 1] * arity))
        np.testing.assert_allclose(f(T), expected)
    assert set(ARITY) == set(FUNCTIONS)


def test_numbers_give_constant_functions() -> None:
    assert compile_expression(2, "x")(T).tolist() == [2.0] * T.size
    assert compile_expression(-0.5, "x")(np.zeros((2, 3))).shape == (2, 3)
    assert float(compile_expression("0.2 + sin(0.5*t)", "x")(0.0)) == pytest.approx(0.2)


REJECTED = {
    # text: (piece of the message)
    "__import__('os')": "unknown function '__import__'",
    "__import__('os').system('true')": "Attribute",
    "t.real": "Attribute",
    "t.__class__": "Attribute",
    "np.sin(t)": "Attribute",
    "x": "unknown name 'x'",
    "os": "unknown name 'os'",
    "__builtins__": "unknown name '__builtins__'",
    "open('f')": "unknown function 'open'",
    "eval('1')": "unknown function 'eval'",
    "min(t, 1)": "unknown function 'min'",
    "sin": "'sin' is a function",
    "sin(t)(t)": "only the functions",
    "lambda: 1": "Lambda",
    "(lambda t: t)(1)": "Lambda",
    "[t][0]": "Subscript",
    "t[0]": "Subscript",
    "'abc'": "only numbers are allowed",
    "b'abc'": "only numbers are allowed",
    "True": "only numbers are allowed",
    "None": "only numbers are allowed",
    "1j": "only numbers are allowed",
    "[1, 2]": "List",
    "(1, 2)": "Tuple",
    "{1: 2}": "Dict",
    "[i for i in t]": "ListComp",
    "t if t > 1 else 0": "IfExp",
    "t and 1": "BoolOp",
    "not t": "Not",
    "~t": "Invert",
    "t == 1": "unsupported comparison",
    "t != 1": "unsupported comparison",
    "t // 2": "FloorDiv",
    "t << 1": "LShift",
    "t @ t": "MatMult",
    "sin()": "sin() takes 1",
    "sin(t, 2)": "sin() takes 1",
    "minimum(t)": "minimum() takes 2",
    "sin(x=t)": "sin() takes 1",
    "sin(*t)": "Starred",
    "(t := 1)": "NamedExpr",
    "f'{t}'": "JoinedStr",
    "1 +": "cannot parse",
    "": "cannot parse",
    "t\x00": "cannot parse",
}


@pytest.mark.parametrize("text", sorted(REJECTED))
def test_rejects_everything_else(text: str) -> None:
    with pytest.raises(ModelFileError) as exc:
        compile_expression(text, "simulation.u[0]")
    message = str(exc.value)
    assert message.startswith("simulation.u[0]: ")
    assert REJECTED[text] in message, message
    assert exc.value.argument == "simulation.u[0]"
    assert "\n" not in message


@pytest.mark.parametrize("value", [True, None, [1.0], {"t": 1}, float("inf"), float("nan")])
def test_rejects_non_expressions(value: object) -> None:
    with pytest.raises(ModelFileError, match=r"^g: "):
        compile_expression(value, "g")


def test_long_and_deep_expressions_are_rejected_cleanly() -> None:
    with pytest.raises(ModelFileError, match="longer than"):
        compile_expression("1+" * MAX_LENGTH + "1", "x")
    with pytest.raises(ModelFileError, match="cannot parse"):
        compile_expression("(" * 300 + "t" + ")" * 300, "x")
    # just under the limit: a legal chain still evaluates exactly
    n = (MAX_LENGTH - 1) // 2
    assert compile_expression("1+" * n + "1", "x")(np.zeros(2)).tolist() == [n + 1.0] * 2


def test_non_finite_values_are_reported_where_they_occur() -> None:
    f = compile_expression("1/(t - 2)", "gain")
    np.testing.assert_allclose(f(np.array([3.0, 4.0])), [1.0, 0.5])
    with pytest.raises(ModelFileError, match=r"gain: .* not finite .* t = 2"):
        f(np.array([1.0, 2.0, 3.0]))
    with pytest.raises(ModelFileError, match="not finite"):
        compile_expression("log(t)", "x")(np.array([0.0, 1.0]))


def test_no_python_evaluation_side_effects(tmp_path: object) -> None:
    """Code that would run under eval never runs: the checker rejects it first."""
    import builtins

    calls: list[str] = []
    original = builtins.__import__

    def spy(name: str, *args: object, **kwargs: object) -> object:
        calls.append(name)
        return original(name, *args, **kwargs)

    builtins.__import__ = spy
    try:
        with pytest.raises(ModelFileError):
            compile_expression("__import__('os').system('echo pwned')", "x")
    finally:
        builtins.__import__ = original
    assert "os" not in calls


@given(
    a=st.floats(-1e3, 1e3, allow_nan=False),
    b=st.floats(-1e3, 1e3, allow_nan=False),
    c=st.floats(0.01, 10.0),
)
def test_arithmetic_matches_numpy(a: float, b: float, c: float) -> None:
    text = f"({a!r})*t + ({b!r}) - t/({c!r}) + sin({c!r}*t)"
    f = compile_expression(text, "x")
    np.testing.assert_allclose(f(T), a * T + b - T / c + np.sin(c * T), rtol=1e-12, atol=1e-9)
