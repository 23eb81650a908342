from __future__ import annotations

import ast
import math
import re
import time
import timeit

import pytest

from carlaverse.expr import (
    EVALUATION_BUDGET_S,
    FUNCTIONS,
    MATH_FUNCTIONS,
    MAX_NODES,
    ExpressionError,
    check_cost,
    compile_curve,
)


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


# --- A shared config can never stall a loop (issue 39.5) -----------------------------------
# The bombs of the attack report: Python ints reached `**` through floor/round, and
# 30000**30000 took 10 ms, 1e6**1e6 seconds, 1e9**1e9 all the memory. A tower of constants and
# a literal beyond the float range are the same attack without floor; a long or deep
# expression is the slow path without any large number.
BOMBS = [
    "floor(3e4)**floor(3e4) % floor(7)",
    "floor(1e6)**floor(1e6) % floor(7)",
    "floor(1e9)**floor(1e9) % floor(7)",
    "round(1e9)**round(1e9)",
    "9**9**9",
    "2**2**2**2**2**2 * x",
    "9" * 400 + " * x",
    " ** ".join(["x"] * 40),  # a power tower of the variable: 79 nodes
    " + ".join(["x"] * 120),  # 479 characters, under the length limit
    "sgn(" * 30 + "x" + ")" * 30,  # 61 nodes, nested 31 deep
]


@pytest.mark.timeout(10)  # the refusal itself must not hang
@pytest.mark.parametrize("text", BOMBS)
def test_bombs_are_refused_when_compiled_in_one_line_and_at_once(text: str) -> None:
    start = time.perf_counter()
    with pytest.raises(ExpressionError) as err:
        compile_curve(text)
    # 50 ms: a parse and a walk of at most 500 characters; the 1e6 bomb took seconds.
    assert time.perf_counter() - start < 0.05
    message = str(err.value)
    assert "\n" not in message and text[:40] in message


# Every value is a float: no whitelisted function may hand an int to `**` (an int power of
# an int is exact, hence unbounded in time and memory; a float power is one libm call).
ARGUMENTS = {1: (0.5,), 2: (0.5, 0.25), 3: (0.5, 0.0, 1.0)}  # inside every domain


@pytest.mark.parametrize("name", sorted(FUNCTIONS) + [f"math.{n}" for n in MATH_FUNCTIONS])
def test_every_function_returns_a_float(name: str) -> None:
    func = MATH_FUNCTIONS[name[5:]] if name.startswith("math.") else FUNCTIONS[name]
    results = []
    for args in ARGUMENTS.values():
        try:
            results.append(func(*args))
        except TypeError:  # not this arity
            continue
    assert results and all(type(r) is float for r in results), (name, results)


def test_a_power_that_overflows_fails_fast_instead_of_growing() -> None:
    # floor(x) ** floor(x) at x = 30000: 30000^30000 ≈ 10^134313, far beyond a double
    # (max ≈ 1.8·10^308), so a float power overflows at once; the old int power took 10 ms.
    curve = compile_curve("floor(x) ** floor(x) % floor(7)")
    start = time.perf_counter()
    with pytest.raises(ExpressionError, match=r"failed at x=30000"):
        curve(3e4)
    assert time.perf_counter() - start < 1e-3


def test_a_result_that_is_not_finite_is_an_error() -> None:
    # 1e200 * 1e200 = 1e400 > the largest double: inf, which no axis can use.
    with pytest.raises(ExpressionError, match=r"gave inf at x=1e\+200"):
        compile_curve("x * x")(1e200)


def test_constant_parts_are_computed_once_when_compiled() -> None:
    # tanh(3) = (e^6 − 1)/(e^6 + 1) = 0.995055; the whole quotient at x = 1 is 1.
    curve = compile_curve("math.tanh(3 * x) / math.tanh(3)")
    assert curve(1.0) == pytest.approx(1.0)
    assert compile_curve("floor(2.7) + round(0.4) + ceil(0.2)")(0.0) == 3.0  # 2 + 0 + 1


def _nested(template: str, levels: int) -> str:
    text = "x"
    for _ in range(levels):
        text = template.format(text)
    return text


# The heaviest expressions the bounds admit (64 nodes each, see MAX_NODES): the slowest
# constructs there are, a Python-level function per level or a 63-term comparison chain.
HEAVIEST = [
    _nested("deadzone({}, 0.001)", 21),  # 3 nodes a level + x
    "-abs(" + _nested("round({}, 1e300)", 20) + ")",  # 3 nodes a level + x + 3
    " < ".join(["x"] * 63),
    "min(" + ", ".join(["x"] * 62) + ")",
    "math.hypot(" + ", ".join(["x"] * 61) + ")",
]


@pytest.mark.parametrize("text", HEAVIEST)
def test_the_heaviest_legal_expressions_fit_the_budget(text: str) -> None:
    nodes = sum(isinstance(n, ast.expr) for n in ast.walk(ast.parse(text, mode="eval")))
    assert nodes == MAX_NODES, nodes  # the bound itself, not a lighter case
    xs = [i / 20.0 for i in range(-20, 21)]
    curve = compile_curve(text)
    assert check_cost(text, curve, xs) <= EVALUATION_BUDGET_S
    # and the budget leaves the loop its tick: four axes at the budget are a tenth of 1 ms
    assert 4 * EVALUATION_BUDGET_S <= 0.1 * 1e-3


def test_cost_over_budget_is_refused_naming_the_measured_cost() -> None:
    def one_ms(x: float) -> float:  # an evaluation known to take 1 ms: a spin on the clock
        end = time.perf_counter() + 1e-3
        while time.perf_counter() < end:
            pass
        return x

    with pytest.raises(ExpressionError) as err:
        check_cost("slow", one_ms, [0.0, 0.5, 1.0])
    found = re.search(r"too costly \(([\d.]+) µs per evaluation > 25 µs budget\)", str(err.value))
    assert found is not None, str(err.value)
    assert 1000.0 <= float(found.group(1)) < 5000.0  # at least the spin; the min of 5 passes
