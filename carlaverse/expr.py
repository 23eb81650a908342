"""A restricted compiler for control-curve expressions written in YAML.

Researchers shape inputs with one-line formulas (`sgn(x) * abs(x) ** 1.8`, `math.pow(x, 2)`,
`clamp(2*x, -1, 1)`); the paper compiles them at run time. A shared config must never be able
to run code, so instead of `eval` on the text we parse it with `ast`, accept only a small
grammar — numbers, the variable `x`, arithmetic, comparisons, `a if c else b`, and calls of
whitelisted maths functions — and build a closure tree from it. Everything else is refused
with an error that quotes the expression.

Scenario triggers use the same grammar over named measurements instead of `x`
(`compile_condition`), with `and`, `or` and `not` added.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping

Curve = Callable[[float], float]
_Node = Callable[[float], float]


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
    "floor": math.floor,
    "ceil": math.ceil,
    "round": round,
}
# `math.<name>` is accepted for these; `math.__dict__` and friends are not.
MATH_FUNCTIONS = {
    name: getattr(math, name)
    for name in (
        "pow", "sqrt", "exp", "log", "log10", "sin", "cos", "tan", "asin", "acos", "atan",
        "atan2", "sinh", "cosh", "tanh", "floor", "ceil", "fabs", "copysign", "hypot",
        "radians", "degrees",
    )
}  # fmt: skip
CONSTANTS = {"pi": math.pi, "e": math.e}

_BINARY = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
    ast.Div: operator.truediv, ast.Pow: operator.pow, ast.Mod: operator.mod,
    ast.FloorDiv: operator.floordiv,
}  # fmt: skip
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Not: operator.not_}
_COMPARE = {
    ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt,
    ast.GtE: operator.ge, ast.Eq: operator.eq, ast.NotEq: operator.ne,
}  # fmt: skip
_MAX_LENGTH = 500


def compile_curve(text: str) -> Curve:
    """Compile `text` (a formula in `x`) into a fast callable; raise ExpressionError otherwise."""
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError(f"empty expression {text!r}")
    if len(text) > _MAX_LENGTH:
        raise ExpressionError(f"expression longer than {_MAX_LENGTH} characters: {text[:40]!r}…")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"cannot parse expression {text!r}: {exc.msg}") from exc
    body = _Compiler(text).build(tree.body)

    def curve(x: float) -> float:
        try:
            return float(body(x))
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise ExpressionError(f"expression {text!r} failed at x={x!r}: {exc}") from exc

    curve.__doc__ = f"y = {text}"
    return curve


def compile_condition(text: str, names: set[str]) -> Callable[[Mapping[str, float]], bool]:
    """Compile a condition over the measurements `names` (e.g. `eta_bike < 4 and not done`);
    raise ExpressionError for anything outside the grammar or an unknown name."""
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError(f"empty condition {text!r}")
    if len(text) > _MAX_LENGTH:
        raise ExpressionError(f"condition longer than {_MAX_LENGTH} characters: {text[:40]!r}…")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"cannot parse condition {text!r}: {exc.msg}") from exc
    body = _Compiler(text, frozenset(names)).build(tree.body)

    def condition(values: Mapping[str, float]) -> bool:
        try:
            return bool(body(values))
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise ExpressionError(f"condition {text!r} failed: {exc}") from exc

    return condition


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
        return method(node)

    def _Constant(self, node: ast.Constant) -> _Node:
        value = node.value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.refuse(node, f"the constant {value!r}")
        v = float(value)
        return lambda x: v

    def _Name(self, node: ast.Name) -> _Node:
        if self.names is None and node.id == "x":
            return lambda x: x
        if self.names is not None and node.id in self.names:
            name = node.id
            return lambda env: env[name]
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
        return lambda x: func(*(a(x) for a in args))

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
