"""Safe arithmetic expressions in case files.

Boundary values and loads may be given as strings such as ``"1.5*U*4*y*(H - y)/H**2"``. They
are parsed once with :mod:`ast`, checked against a whitelist (numbers, the names ``x``, ``y``,
``t``, case parameters, a few math functions, ``+ - * / **`` and unary minus) and evaluated
with numpy so that they accept arrays of coordinates.

The sandbox: every number literal is made a float before evaluation, so no operation works on
unbounded Python integers (``10**10**10`` overflows at once instead of running for hours);
the text length is bounded; and each expression is evaluated once when it is read, so a
constant part that divides by zero or overflows is an input error naming the key rather than
a failure during the run.
"""

from __future__ import annotations

import ast
import math
from typing import Any, Mapping

import numpy as np

from fsci.errors import InputError

FUNCTIONS = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log, "sqrt": np.sqrt,
    "abs": np.abs, "tanh": np.tanh, "sinh": np.sinh, "cosh": np.cosh, "arctan2": np.arctan2,
    "minimum": np.minimum, "maximum": np.maximum, "floor": np.floor,
}
CONSTANTS = {"pi": math.pi, "e": math.e}
_BINOPS = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)
VARIABLES = ("x", "y", "t")
MAX_LENGTH = 100_000  # characters of one expression (manufactured solutions are long)


class _Floats(ast.NodeTransformer):
    """Number literals → float literals (bounded cost of every operation)."""

    def visit_Constant(self, node: ast.Constant) -> ast.Constant:
        if isinstance(node.value, int) and not isinstance(node.value, bool):
            return ast.copy_location(ast.Constant(float(node.value)), node)
        return node


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
        if len(text) > MAX_LENGTH:
            raise InputError(field, text[:40] + "...", f"an expression of at most {MAX_LENGTH} characters")
        try:
            tree = ast.parse(text, mode="eval")
            self._check(tree.body)
            names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
            self.uses_time = "t" in names
            tree = ast.fix_missing_locations(_Floats().visit(tree))
            self._code = compile(tree, f"<{field}>", "eval")
        except SyntaxError as exc:
            raise InputError(field, text, f"a valid arithmetic expression ({exc.msg})") from None
        except (RecursionError, MemoryError):
            raise InputError(field, text[:40], "an expression nested less deeply") from None
        except OverflowError:
            raise InputError(field, text, "numbers within the floating-point range") from None
        self._constant: float | None = None
        value = self(0.0, 0.0, 0.0)  # a failing constant part is an input error now, not during the run
        if not names & set(VARIABLES):
            # no x, y or t: the value is made once (boundary conditions are asked for at every step)
            self._constant = float(value)

    def _check(self, node: ast.AST) -> None:
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return
        if isinstance(node, ast.Name):
            if node.id in VARIABLES or node.id in CONSTANTS or node.id in self.params:
                return
            allowed = ", ".join(list(VARIABLES) + sorted(self.params) + sorted(CONSTANTS))
            raise InputError(self.field, self.text, f"unknown name '{node.id}' (allowed: {allowed})")
        if isinstance(node, ast.BinOp) and isinstance(node.op, _BINOPS):
            self._check(node.left)
            self._check(node.right)
            return
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            self._check(node.operand)
            return
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS \
                and not node.keywords:
            for a in node.args:
                self._check(a)
            return
        raise InputError(self.field, self.text, "only numbers, x, y, t, parameters, + - * / ** and "
                         + ", ".join(sorted(FUNCTIONS)) + " are allowed")

    def __call__(self, x: Any = 0.0, y: Any = 0.0, t: float = 0.0) -> np.ndarray:
        if self._constant is not None:
            return np.full(np.broadcast(np.asarray(x), np.asarray(y)).shape, self._constant)
        env: dict[str, Any] = dict(FUNCTIONS)
        env.update(CONSTANTS)
        env.update(self.params)
        # numpy scalars and arrays: a division by zero in x, y or t gives inf, as in the field
        env.update(x=np.asarray(x, dtype=float), y=np.asarray(y, dtype=float), t=np.float64(t))
        try:
            with np.errstate(all="ignore"):
                val = eval(self._code, {"__builtins__": {}}, env)  # noqa: S307 - whitelisted AST
            return np.broadcast_to(np.asarray(val, dtype=float),
                                   np.broadcast(np.asarray(x), np.asarray(y)).shape).copy()
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise InputError(self.field, self.text, f"an expression that can be evaluated ({exc})") from None

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
    """Evaluate strings starting with ``=`` as constant expressions of the parameters; the
    result must be a finite number."""
    if isinstance(value, str) and value.startswith("="):
        v = float(Expression(value[1:], params, field)(0.0, 0.0, 0.0))
        if not math.isfinite(v):
            raise InputError(field, value, "an expression with a finite value")
        return v
    return value
