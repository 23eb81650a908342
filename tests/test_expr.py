from __future__ import annotations

import math
import timeit

import pytest

from carlaverse.expr import ExpressionError, compile_curve


@pytest.mark.parametrize(
    "text,x,expected",
    [
        ("sgn(x) * abs(x) ** 1.8", -0.5, -(0.5**1.8)),
        ("math.pow(x, 2)", 3.0, 9.0),
        ("clamp(2 * x, -1, 1)", 0.8, 1.0),
        ("clamp(x)", -3.0, -1.0),
        ("0 if abs(x) < 0.05 else x", 0.01, 0.0),
        ("-x if x < 0 else x", -2.0, 2.0),
        ("math.tanh(3 * x) / math.tanh(3)", 1.0, 1.0),
        ("deadzone(x, 0.1)", 0.55, 0.5),
        ("pi * x", 1.0, math.pi),
        ("(x + 1) / 2", -1.0, 0.0),
    ],
)
def test_curves_evaluate(text: str, x: float, expected: float) -> None:
    assert compile_curve(text)(x) == pytest.approx(expected)


@pytest.mark.parametrize(
    "text",
    [
        "__import__('os')",
        "().__class__",
        "open('x')",
        "lambda: 0",
        "[i for i in x]",
        "y",
        "math.__dict__",
        "'a'",
        "x.real",
        "exec('1')",
        "globals()",
        "f'{x}'",
        "x if y else 1",
        "math.sys",
        "(lambda: 1)()",
        "{1: 2}",
        "x[0]",
        "abs(*x)",
        "abs(x=1)",
        "True",
        "x := 1",
        "__builtins__",
        "x @ x",
        "not x",
        "x and 1",
    ],
)
def test_anything_but_arithmetic_is_refused_quoting_the_expression(text: str) -> None:
    with pytest.raises(ExpressionError) as err:
        compile_curve(text)
    assert repr(text) in str(err.value) or "cannot parse" in str(err.value)


def test_evaluation_errors_name_expression_and_input() -> None:
    curve = compile_curve("1 / x")
    with pytest.raises(ExpressionError, match=r"'1 / x' failed at x=0"):
        curve(0.0)


def test_compiled_once_and_fast() -> None:
    curve = compile_curve("sgn(x) * abs(x) ** 1.8")
    per_call = timeit.timeit(lambda: curve(0.3), number=20_000) / 20_000
    assert per_call < 20e-6  # a 1 kHz control loop can afford several of these
