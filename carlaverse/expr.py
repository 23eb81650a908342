"""A restricted compiler for control-curve expressions written in YAML.

Researchers shape inputs with one-line formulas (`sgn(x) * abs(x) ** 1.8`, `math.pow(x, 2)`,
`clamp(2*x, -1, 1)`); the paper compiles them at run time. A shared config must never be able
to run code, so instead of `eval` on the text we parse it with `ast`, accept only a small
grammar — numbers, the variable `x`, arithmetic, comparisons, `a if c else b`, and calls of
whitelisted maths functions — and build a closure tree from it. Everything else is refused
with an error that quotes the expression.

Nor may a shared config stall the loop that evaluates it (a 1 kHz control loop has 1000 µs a
tick), so an expression's cost is bounded by construction:
- every value is a float: literals are converted, `floor`/`ceil`/`round` return floats and `**`
  is `math.pow`, so no operation can build a huge integer (Python's `int ** int` can take
  seconds and gigabytes); a float overflow is an error, not a slow result;
- at most `MAX_NODES` expression nodes nested at most `MAX_DEPTH` deep, so one evaluation is a
  bounded number of constant-time steps whatever branch it takes;
- parts without a variable (`9 ** 9 ** 9`) are computed once, at compile time, where a failure
  is refused with the expression quoted;
- `check_cost` times a compiled curve over its input grid when a config loads.

Scenario triggers use the same grammar over named measurements instead of `x`
(`compile_condition`), with `and`, `or` and `not` added.
"""

from __future__ import annotations

import ast
import math
import operator
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

Curve = Callable[[float], float]
_Node = Callable[[Any], float]  # of x (a curve) or of the measurements (a condition)


class ExpressionError(ValueError):
    """An expression outside the allowed grammar, or one that cannot be evaluated."""


def _sgn(v: float) -> float:
    return 1.0 if v > 0 else -1.0 if v < 0 else 0.0


def _clamp(v: float, lo: float = -1.0, hi: float = 1.0) -> float:
    return lo if v < lo else hi if v > hi else v


def _deadzone(v: float, width: float) -> float:
    """Zero inside ±width, rescaled outside so the output still reaches ±1."""
    if abs(v) <= width:
        return 0.0
    return _sgn(v) * (abs(v) - width) / (1.0 - width)


# Python's own floor, ceil and round return ints, and an int reaching `**` is unbounded.
def _floor(v: float) -> float:
    return float(math.floor(v))


def _ceil(v: float) -> float:
    return float(math.ceil(v))


def _round(v: float, digits: float = 0.0) -> float:
    # Beyond ±400 digits a double rounds to itself or to 0 anyway; the clamp keeps `int()`
    # from building a thousand-bit integer out of `1e300` on every call.
    return float(round(v, int(_clamp(digits, -400.0, 400.0))))


def _not(v: float) -> float:
    return 0.0 if v else 1.0


FUNCTIONS: dict[str, Callable[..., float]] = {
    "abs": abs,
    "sgn": _sgn,
    "sign": _sgn,
    "min": min,
    "max": max,
    "clamp": _clamp,
    "deadzone": _deadzone,
    "pow": math.pow,
    "sqrt": math.sqrt,
    "exp": math.exp,
    "log": math.log,
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "atan": math.atan,
    "atan2": math.atan2,
    "tanh": math.tanh,
    "floor": _floor,
    "ceil": _ceil,
    "round": _round,
}
# `math.<name>` is accepted for these; `math.__dict__` and friends are not.
MATH_FUNCTIONS: dict[str, Callable[..., float]] = {
    name: getattr(math, name)
    for name in (
        "pow", "sqrt", "exp", "log", "log10", "sin", "cos", "tan", "asin", "acos", "atan",
        "atan2", "sinh", "cosh", "tanh", "fabs", "copysign", "hypot", "radians", "degrees",
    )
} | {"floor": _floor, "ceil": _ceil}  # fmt: skip
CONSTANTS = {"pi": math.pi, "e": math.e}

_BINARY = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
    ast.Div: operator.truediv, ast.Pow: math.pow, ast.Mod: operator.mod,
    ast.FloorDiv: operator.floordiv,
}  # fmt: skip
_UNARY: dict[type[ast.unaryop], Callable[[Any], Any]] = {
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
    ast.Not: _not,
}
_COMPARE = {
    ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt,
    ast.GtE: operator.ge, ast.Eq: operator.eq, ast.NotEq: operator.ne,
}  # fmt: skip
_MAX_LENGTH = 500  # [characters]
# A curve with a dead zone and three piecewise segments needs about 40 nodes; the shipped
# curves need under 10.
MAX_NODES = 64
MAX_DEPTH = 24  # each level is two Python frames when evaluated
# [s] per evaluation, measured at load. A drive loop evaluates up to four curves in a 1000 µs
# tick (steer, throttle, brake, clutch): at 25 µs each they take a tenth of it, beside ~20 µs
# of physics. The node bound does the real work: the heaviest legal expressions (64 nodes of
# nested `deadzone`, `round`, chained `<`) cost ~5 µs on a 2-core 2020s host, so this timed
# backstop has 5x headroom for slower or loaded hosts.
EVALUATION_BUDGET_S = 25e-6
COST_REPEATS = 5  # timed passes; the fastest counts (a loaded host only ever adds time)


def compile_curve(text: str) -> Curve:
    """Compile `text` (a formula in `x`) into a fast callable; raise ExpressionError otherwise.

    The callable raises ExpressionError when the formula fails or gives inf or nan at `x`."""
    body = _Compiler(text).build(_parse(text, "expression"))

    def curve(x: float) -> float:
        try:
            y = float(body(float(x)))
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise ExpressionError(f"expression {text!r} failed at x={x!r}: {exc}") from exc
        if not math.isfinite(y):
            raise ExpressionError(f"expression {text!r} gave {y} at x={x!r}")
        return y

    curve.__doc__ = f"y = {text}"
    return curve


def compile_condition(text: str, names: set[str]) -> Callable[[Mapping[str, float]], bool]:
    """Compile a condition over the measurements `names` (e.g. `eta_bike < 4 and not done`);
    raise ExpressionError for anything outside the grammar or an unknown name."""
    body = _Compiler(text, frozenset(names)).build(_parse(text, "condition"))

    def condition(values: Mapping[str, float]) -> bool:
        try:
            return bool(body(values))
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise ExpressionError(f"condition {text!r} failed: {exc}") from exc

    return condition


def check_cost(
    text: str, curve: Curve, xs: Sequence[float], budget_s: float = EVALUATION_BUDGET_S
) -> float:
    """Seconds one evaluation of `curve` takes over the inputs `xs` (the fastest of
    COST_REPEATS passes); ExpressionError when that exceeds `budget_s`."""
    best = math.inf
    for _ in range(COST_REPEATS):
        start = time.perf_counter()
        for x in xs:
            curve(x)
        best = min(best, time.perf_counter() - start)
    cost = best / len(xs)
    if cost > budget_s:
        raise ExpressionError(
            f"expression {text!r} too costly ({cost * 1e6:.1f} µs per evaluation > "
            f"{budget_s * 1e6:.0f} µs budget); simplify it"
        )
    return cost


def _parse(text: str, what: str) -> ast.expr:
    """The expression's syntax tree, refused when too long, too large or too deep."""
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError(f"empty {what} {text!r}")
    if len(text) > _MAX_LENGTH:
        raise ExpressionError(f"{what} longer than {_MAX_LENGTH} characters: {text[:40]!r}…")
    try:
        body = ast.parse(text.strip(), mode="eval").body
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        reason = exc.msg if isinstance(exc, SyntaxError) else type(exc).__name__
        raise ExpressionError(f"cannot parse {what} {text!r}: {reason}") from exc
    nodes = sum(isinstance(n, ast.expr) for n in ast.walk(body))
    if nodes > MAX_NODES:
        raise ExpressionError(
            f"{what} {text!r} has {nodes} parts (numbers, names, operators, calls); "
            f"at most {MAX_NODES} are allowed"
        )
    if _depth(body) > MAX_DEPTH:
        raise ExpressionError(f"{what} {text!r} nests deeper than {MAX_DEPTH} levels")
    return body


def _depth(node: ast.AST) -> int:
    """Nesting depth of expression nodes (recursion is safe: their count is bounded already)."""
    children = (c for c in ast.iter_child_nodes(node) if isinstance(c, ast.expr))
    return 1 + max((_depth(c) for c in children), default=0)


class _Compiler:
    """Builds closures of one argument: the value of `x` for a curve, or the mapping of
    measurement names to values for a condition (`names` given)."""

    def __init__(self, text: str, names: frozenset[str] | None = None) -> None:
        self.text = text
        self.names = names

    def refuse(self, node: ast.AST, what: str) -> ExpressionError:
        col = getattr(node, "col_offset", 0)
        variables = "x" if self.names is None else ", ".join(sorted(self.names)) or "no names"
        logic = "" if self.names is None else ", and or not"
        return ExpressionError(
            f"{what} is not allowed in expression {self.text!r} (at column {col + 1}); "
            f"use numbers, {variables}, + - * / ** %, comparisons{logic}, 'a if c else b' and "
            f"the functions {', '.join(sorted(FUNCTIONS))} or math.<name>"
        )

    def build(self, node: ast.AST) -> _Node:
        method = getattr(self, f"_{type(node).__name__}", None)
        if method is None:
            raise self.refuse(node, f"'{type(node).__name__}'")
        closure: _Node = method(node)
        return self._fold(node, closure) if self._is_constant(node) else closure

    def _is_constant(self, node: ast.AST) -> bool:
        """No variable below `node` (function names and `math.` are not variables)."""
        nodes = list(ast.walk(node))
        callees = {id(n.func) for n in nodes if isinstance(n, ast.Call)}
        callees |= {id(n.value) for n in nodes if isinstance(n, ast.Attribute)}
        variables = {"x"} if self.names is None else self.names
        return not any(
            isinstance(n, ast.Name) and id(n) not in callees and n.id in variables for n in nodes
        )

    def _fold(self, node: ast.AST, closure: _Node) -> _Node:
        """Compute a constant part now: once, and any failure refused at load."""
        try:
            v = float(closure(None))
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise ExpressionError(
                f"{ast.unparse(node)!r} in expression {self.text!r} cannot be computed: {exc}"
            ) from exc
        return lambda x: v

    def _Constant(self, node: ast.Constant) -> _Node:
        value = node.value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.refuse(node, f"the constant {value!r}")
        try:
            v = float(value)
        except OverflowError as exc:
            raise self.refuse(node, f"the number {ast.unparse(node)[:20]}… (too large)") from exc
        return lambda x: v

    def _Name(self, node: ast.Name) -> _Node:
        if self.names is None and node.id == "x":
            return lambda x: x
        if self.names is not None and node.id in self.names:
            name = node.id
            return lambda env: float(env[name])
        if node.id in CONSTANTS:
            v = CONSTANTS[node.id]
            return lambda x: v
        raise self.refuse(node, f"the name {node.id!r}")

    def _BinOp(self, node: ast.BinOp) -> _Node:
        op = _BINARY.get(type(node.op))
        if op is None:
            raise self.refuse(node, f"the operator {type(node.op).__name__}")
        left, right = self.build(node.left), self.build(node.right)
        return lambda x: op(left(x), right(x))

    def _UnaryOp(self, node: ast.UnaryOp) -> _Node:
        op = _UNARY.get(type(node.op))
        if op is None or (self.names is None and isinstance(node.op, ast.Not)):
            raise self.refuse(node, f"the operator {type(node.op).__name__}")
        operand = self.build(node.operand)
        return lambda x: op(operand(x))

    def _Compare(self, node: ast.Compare) -> _Node:
        parts = [self.build(node.left), *(self.build(c) for c in node.comparators)]
        ops = []
        for op_node in node.ops:
            op = _COMPARE.get(type(op_node))
            if op is None:
                raise self.refuse(node, f"the comparison {type(op_node).__name__}")
            ops.append(op)

        def compare(x: float) -> float:
            values = [p(x) for p in parts]
            return float(all(op(a, b) for op, a, b in zip(ops, values, values[1:], strict=False)))

        return compare

    def _BoolOp(self, node: ast.BoolOp) -> _Node:
        if self.names is None:
            raise self.refuse(node, f"'{type(node.op).__name__.lower()}'")
        parts = [self.build(v) for v in node.values]
        if isinstance(node.op, ast.And):
            return lambda x: float(all(p(x) for p in parts))
        return lambda x: float(any(p(x) for p in parts))

    def _IfExp(self, node: ast.IfExp) -> _Node:
        test, body, orelse = self.build(node.test), self.build(node.body), self.build(node.orelse)
        return lambda x: body(x) if test(x) else orelse(x)

    def _Call(self, node: ast.Call) -> _Node:
        if node.keywords:
            raise self.refuse(node, "a keyword argument")
        func = self._function(node.func)
        args = [self.build(a) for a in node.args]
        if len(args) == 1:  # the common arities without building an argument tuple
            (a,) = args
            return lambda x: func(a(x))
        if len(args) == 2:
            a, b = args
            return lambda x: func(a(x), b(x))
        return lambda x: func(*[a(x) for a in args])

    def _function(self, node: ast.AST) -> Callable[..., float]:
        if isinstance(node, ast.Name) and node.id in FUNCTIONS:
            return FUNCTIONS[node.id]
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id == "math"
            and node.attr in MATH_FUNCTIONS
        ):
            return MATH_FUNCTIONS[node.attr]
        if isinstance(node, ast.Attribute):
            raise self.refuse(node, f"the attribute '{node.attr}'")
        if isinstance(node, ast.Name):
            raise self.refuse(node, f"the function {node.id!r}")
        raise self.refuse(node, "this kind of call")
