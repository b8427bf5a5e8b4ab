"""Constant folding of typed expressions: what param ranges, defaults, settings and constant phase
arguments need. Anything that depends on the scene (a role, a builtin of entities) is not constant.
"""

from __future__ import annotations

import math

from rapid_dsl.frontend import ir

Value = float | tuple[float, float, float] | bool

# Values of the registry's constants (the registry holds their types; the runtime the same values).
_CONSTANTS: dict[str, Value] = {"pi": math.pi, "up": (0.0, 0.0, 1.0)}


class NotConstant(Exception):
    pass


# id(node) -> (node, its value or None). The node is kept so that its id is not reused.
Memo = dict[int, tuple[ir.Expr, "Value | None"]]


def fold(expr: ir.Expr, memo: Memo | None = None) -> Value | None:
    """The value of `expr` if it is a finite constant, else None (also on overflow or x/0).

    With a `memo` (one per checker), a node is folded once however often it is asked for: the
    checker folds each operand of a chain `1cm + 1cm + ...` as it builds it, which without the
    memo is quadratic in the chain's length."""
    if memo is not None:
        hit = memo.get(id(expr))
        if hit is not None and hit[0] is expr:
            return hit[1]
    value: Value | None
    try:
        value = _fold(expr, memo)
    except (NotConstant, ArithmeticError, ValueError, TypeError):
        value = None
    numbers = value if isinstance(value, tuple) else (value,)
    if not all(isinstance(x, bool) or x is not None and math.isfinite(x) for x in numbers):
        value = None
    if memo is not None:
        memo[id(expr)] = (expr, value)
    return value


def _part(e: ir.Expr, memo: Memo | None) -> Value:
    if memo is None:
        return _fold(e, None)
    value = fold(e, memo)
    if value is None:
        raise NotConstant
    return value


def _fold(e: ir.Expr, memo: Memo | None) -> Value:
    match e:
        case ir.Const(value=value):
            return value
        case ir.BuiltinCall(name=name, args=()) if name in _CONSTANTS:
            return _CONSTANTS[name]
        case ir.Vector(items=items):
            a, b, c = (_scalar(_part(i, memo)) for i in items)
            return (a, b, c)
        case ir.Unary(op="-", operand=operand):
            v = _part(operand, memo)
            return tuple(-x for x in v) if isinstance(v, tuple) else -_scalar(v)  # type: ignore[return-value]
        case ir.Unary(op="not", operand=operand):
            return not _part(operand, memo)
        case ir.Component(target=target, index=index):
            v = _part(target, memo)
            assert isinstance(v, tuple)
            return v[index]
        case ir.Binary(op=op, left=left, right=right):
            return _binary(op, _part(left, memo), _part(right, memo))
        case ir.If(cond=cond, then=then, orelse=orelse):
            return _part(then, memo) if _part(cond, memo) else _part(orelse, memo)
    raise NotConstant


def _scalar(v: Value) -> float:
    if isinstance(v, tuple) or isinstance(v, bool):
        raise NotConstant
    return float(v)


def _binary(op: str, a: Value, b: Value) -> Value:
    if isinstance(a, tuple) or isinstance(b, tuple):
        if op in "+-" and isinstance(a, tuple) and isinstance(b, tuple):
            sign = 1.0 if op == "+" else -1.0
            return tuple(x + sign * y for x, y in zip(a, b, strict=True))  # type: ignore[return-value]
        if op == "*":
            vec, k = (a, b) if isinstance(a, tuple) else (b, a)
            assert isinstance(vec, tuple)
            return tuple(x * _scalar(k) for x in vec)  # type: ignore[return-value]
        if op == "/" and isinstance(a, tuple):
            return tuple(x / _scalar(b) for x in a)  # type: ignore[return-value]
        raise NotConstant
    x, y = _scalar(a), _scalar(b)
    if op == "+":
        return x + y
    if op == "-":
        return x - y
    if op == "*":
        return x * y
    if op == "/":
        return x / y
    result = x ** y
    if isinstance(result, complex) or not math.isfinite(result):
        raise NotConstant
    return result
