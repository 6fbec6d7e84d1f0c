"""Safe evaluation of arithmetic expressions over named model parameters.

Model files may write a number as a string such as ``"-P / 20"`` or ``"2 * mu1 + 0.1"``.
Only numbers, parameter names, ``+ - * / **``, parentheses and a few functions are allowed.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping

from ..errors import ModelError

_BINARY: dict[type[ast.operator], Callable[[float, float], float]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_UNARY: dict[type[ast.unaryop], Callable[[float], float]] = {
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
}
_FUNCTIONS: dict[str, Callable[..., float]] = {
    "sqrt": math.sqrt,
    "sin": math.sin,
    "cos": math.cos,
    "abs": abs,
    "min": min,
    "max": max,
}
_CONSTANTS = {"pi": math.pi}
MAX_EXPRESSION_LENGTH = 1000


def names_in(expression: str) -> set[str]:
    """Parameter names an expression refers to."""
    tree = ast.parse(expression, mode="eval")
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call)
              and isinstance(n.func, ast.Name)}
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} - called - set(_CONSTANTS)


def evaluate(value: object, parameters: Mapping[str, float], field: str,
             infinite: bool = False) -> float:
    """A finite float from a number or an expression string; errors name ``field``.
    ``infinite``: ±inf is accepted too (a parameter's unbounded range)."""
    if isinstance(value, bool):
        raise ModelError(f"{field}: expected a number, got {value!r}")
    if isinstance(value, (int, float)):
        return _finite(float(value), value, field, infinite)
    if not isinstance(value, str):
        raise ModelError(f"{field}: expected a number or an expression, got {value!r}")
    if len(value) > MAX_EXPRESSION_LENGTH:
        raise ModelError(f"{field}: expression of {len(value)} characters (at most "
                         f"{MAX_EXPRESSION_LENGTH})")
    try:
        tree = ast.parse(value, mode="eval")
    except SyntaxError as exc:
        raise ModelError(f"{field}: cannot parse expression {value!r}: {exc.msg}") from None
    except (RecursionError, MemoryError):
        raise ModelError(f"{field}: expression {value[:40]!r}... is nested too deeply") from None

    def walk(node: ast.AST) -> float:
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) \
                and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.Name):
            if node.id in parameters:
                return float(parameters[node.id])
            if node.id in _CONSTANTS:
                return _CONSTANTS[node.id]
            known = ", ".join(sorted(parameters)) or "none"
            raise ModelError(
                f"{field}: expression {value!r} uses unknown parameter {node.id!r} "
                f"(parameters: {known})"
            )
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](walk(node.left), walk(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](walk(node.operand))
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                and node.func.id in _FUNCTIONS and not node.keywords:
            return float(_FUNCTIONS[node.func.id](*(walk(a) for a in node.args)))
        raise ModelError(f"{field}: expression {value!r} contains a disallowed construct")

    try:
        result = walk(tree)
    except ZeroDivisionError:
        raise ModelError(f"{field}: expression {value!r} divides by zero") from None
    except OverflowError:
        raise ModelError(f"{field}: expression {value!r} overflows (beyond ±1.8e308)") from None
    except (ValueError, TypeError) as exc:  # sqrt(-1), min() of nothing, a complex power
        raise ModelError(f"{field}: expression {value!r} cannot be evaluated: {exc}") from None
    except RecursionError:
        raise ModelError(f"{field}: expression {value[:40]!r}... is nested too deeply") from None
    return _finite(result, value, field, infinite)


def _finite(result: float, value: object, field: str, infinite: bool = False) -> float:
    if isinstance(result, complex) or math.isnan(result) or (
            math.isinf(result) and not infinite):
        raise ModelError(f"{field}: {value!r} is not a finite number (gives {result})")
    return float(result)
