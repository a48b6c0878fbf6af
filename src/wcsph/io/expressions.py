"""Initial fields given as formulas of the position: ``velocity = ["-cos(2*pi*x)*sin(2*pi*y)",
"sin(2*pi*x)*cos(2*pi*y)"]`` or ``pressure = "..."`` in a ``[[fluid]]`` block, as PySPH users
write them in Python and DualSPHysics users in its initial-condition options. Only arithmetic,
numbers, the coordinates x, y, z, the constants pi and e and the functions below are allowed:
the text is parsed and checked before it is evaluated, so nothing else can run."""
import ast
import math

import numpy as np

FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log, "sqrt": np.sqrt,
             "abs": np.abs, "tanh": np.tanh, "sinh": np.sinh, "cosh": np.cosh, "arctan2": np.arctan2,
             "minimum": np.minimum, "maximum": np.maximum}
CONSTANTS = {"pi": math.pi, "e": math.e}
_OPS = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.Mod, ast.USub, ast.UAdd)


class ExpressionError(ValueError):
    pass


def check(text, names=("x", "y", "z")):
    """The parsed expression; an ``ExpressionError`` naming what is not allowed."""
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as e:
        raise ExpressionError(f"not a formula: {e.msg}") from None
    for node in ast.walk(tree):
        if isinstance(node, (ast.Expression, ast.Load)) or isinstance(node, _OPS):
            continue
        if isinstance(node, (ast.BinOp, ast.UnaryOp)):
            continue
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) \
                and not isinstance(node.value, bool):
            continue
        if isinstance(node, ast.Name) and (node.id in names or node.id in CONSTANTS or node.id in FUNCTIONS):
            continue
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS \
                and not node.keywords:
            continue
        what = node.id if isinstance(node, ast.Name) else type(node).__name__
        raise ExpressionError(f"{what!r} is not allowed; use numbers, {', '.join(names)}, pi, e, + - * / ** % "
                              f"and {', '.join(sorted(FUNCTIONS))}")
    return tree


def evaluate(text, x, t=None):
    """The formula at the points ``x`` (dim, N) (and time ``t`` where the formula may use
    it), as an (N,) array."""
    tree = check(text, ("x", "y", "z") if t is None else ("x", "y", "z", "t"))
    env = dict(CONSTANTS, **FUNCTIONS)
    if t is not None:
        env["t"] = t
    for a, name in enumerate("xyz"[: x.shape[0]]):
        env[name] = x[a]
    with np.errstate(all="ignore"):
        value = eval(compile(tree, "<formula>", "eval"), {"__builtins__": {}}, env)  # checked above
    return np.broadcast_to(np.asarray(value, dtype=float), (x.shape[1],)).copy()
