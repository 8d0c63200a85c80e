"""Safe arithmetic expressions in case files.

Boundary values and loads may be given as strings such as ``"1.5*U*4*y*(H - y)/H**2"``. They
are parsed once with :mod:`ast`, checked against a whitelist (numbers, the names ``x``, ``y``,
``t``, case parameters, a few math functions, ``+ - * / **`` and unary minus) and evaluated
with numpy so that they accept arrays of coordinates.
"""

from __future__ import annotations

import ast
import math
from typing import Any, Mapping

import numpy as np

from fsci.errors import InputError

_FUNCS = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log, "sqrt": np.sqrt,
    "abs": np.abs, "tanh": np.tanh, "sinh": np.sinh, "cosh": np.cosh, "arctan2": np.arctan2,
    "minimum": np.minimum, "maximum": np.maximum,
}
_CONSTS = {"pi": math.pi, "e": math.e}
_BINOPS = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)
VARIABLES = ("x", "y", "t")


class Expression:
    """A parsed expression ``f(x, y, t)`` with frozen parameter values.

    Parameters
    ----------
    text
        The expression.
    params
        Values of named case parameters it may use.
    field
        Dotted key name for error messages.
    """

    def __init__(self, text: str, params: Mapping[str, float] | None = None, field: str = "expression") -> None:
        self.text = text
        self.field = field
        self.params = dict(params or {})
        try:
            tree = ast.parse(text, mode="eval")
        except SyntaxError as exc:
            raise InputError(field, text, f"a valid arithmetic expression ({exc.msg})") from None
        self._check(tree.body)
        self._code = compile(tree, f"<{field}>", "eval")

    def _check(self, node: ast.AST) -> None:
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return
        if isinstance(node, ast.Name):
            if node.id in VARIABLES or node.id in _CONSTS or node.id in self.params:
                return
            allowed = ", ".join(list(VARIABLES) + sorted(self.params) + sorted(_CONSTS))
            raise InputError(self.field, self.text, f"unknown name '{node.id}' (allowed: {allowed})")
        if isinstance(node, ast.BinOp) and isinstance(node.op, _BINOPS):
            self._check(node.left)
            self._check(node.right)
            return
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            self._check(node.operand)
            return
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCS and not node.keywords:
            for a in node.args:
                self._check(a)
            return
        raise InputError(self.field, self.text, "only numbers, x, y, t, parameters, + - * / ** and "
                         + ", ".join(sorted(_FUNCS)) + " are allowed")

    def __call__(self, x: Any = 0.0, y: Any = 0.0, t: float = 0.0) -> np.ndarray:
        env = dict(_FUNCS)
        env.update(_CONSTS)
        env.update(self.params)
        env.update(x=np.asarray(x, dtype=float), y=np.asarray(y, dtype=float), t=float(t))
        val = eval(self._code, {"__builtins__": {}}, env)  # noqa: S307 - whitelisted AST
        return np.broadcast_to(np.asarray(val, dtype=float), np.broadcast(np.asarray(x), np.asarray(y)).shape).copy()

    def __repr__(self) -> str:
        return f"Expression({self.text!r})"


def make_scalar(value: Any, params: Mapping[str, float], field: str) -> Expression:
    """A number or an expression string → :class:`Expression`."""
    if isinstance(value, bool):
        raise InputError(field, value, "a number or an expression in x, y, t")
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            raise InputError(field, value, "a finite number")
        return Expression(repr(float(value)), params, field)
    if isinstance(value, str):
        return Expression(value, params, field)
    raise InputError(field, value, "a number or an expression in x, y, t")


def evaluate_parameter(value: Any, params: Mapping[str, float], field: str) -> Any:
    """Evaluate strings starting with ``=`` as constant expressions of the parameters."""
    if isinstance(value, str) and value.startswith("="):
        expr = Expression(value[1:], params, field)
        return float(expr(0.0, 0.0, 0.0))
    return value
