"""Constants in generated code: folding arithmetic on numbers, their Python text, and the source
form shown beside them (`0.2617993877991494  # 15deg`), made from value and dimension only.
"""

from __future__ import annotations

import math

from rapid_dsl.compiler.errors import InternalCompilerError
from rapid_dsl.frontend import ir
from rapid_dsl.language.units import ANGLE, FORCE, LENGTH, MASS, TIME, Dim, si_unit


def fold_number(e: ir.Expr) -> float | None:
    """The value of arithmetic on number constants (`1cm / 1s`), else None."""
    match e:
        case ir.Const(value=float() | int() as value) if not isinstance(value, bool):
            return float(value)
        case ir.Unary(op="-", operand=operand):
            inner = fold_number(operand)
            return None if inner is None else -inner
        case ir.Binary(op=op, left=left, right=right):
            a, b = fold_number(left), fold_number(right)
            if a is None or b is None:
                return None
            try:
                result = {"+": a + b, "-": a - b, "*": a * b}.get(op)
                if op == "/":
                    result = a / b
                elif op == "^":
                    result = float(a ** b)
            except (ArithmeticError, TypeError):
                return None
            return result if result is not None and math.isfinite(result) else None
    return None


def constant_text(value: object, vec: str) -> str:
    """Python text of a constant: `True`, `0.05`, or `vec(0.01, 0.0, 0.0)` for a vector."""
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, tuple):
        return f"{vec}({', '.join(number(float(x)) for x in value)})"
    return number(float(value))  # type: ignore[arg-type]


# The unit a constant of each dimension is shown in: lengths from 1 m in m, from 1 cm in cm, below
# in mm; other dimensions in their SI unit.
_SHOWN: dict[Dim, tuple[str, float]] = {ANGLE: ("deg", 180.0 / math.pi), TIME: ("s", 1.0),
                                        MASS: ("kg", 1.0), FORCE: ("N", 1.0)}


def source_form(value: float | int | tuple[float, ...], dim: Dim) -> str:
    """A folded constant as a person would write it, made from its value and dimension only (never
    from program text): the note beside it in generated code. "" for a dimensionless one.

    >>> source_form(0.2617993877991494, ANGLE), source_form((0.01, 0.0, 0.0), LENGTH)
    ('15deg', '[1, 0, 0]cm')
    """
    if dim.is_dimensionless:
        return ""
    items = value if isinstance(value, tuple) else (value,)
    size = max(abs(float(x)) for x in items)
    if dim == LENGTH:
        unit, factor = ("m", 1.0) if size >= 1 else ("cm", 100.0) if size >= 0.01 or size == 0 \
            else ("mm", 1000.0)
    else:
        unit, factor = _SHOWN.get(dim, (si_unit(dim), 1.0))
    digits = [f"{float(x) * factor:.6g}" for x in items]
    return (f"[{', '.join(digits)}]" if isinstance(value, tuple) else digits[0]) + unit


def number(x: float) -> str:
    if x != x or x in (float("inf"), float("-inf")):
        raise InternalCompilerError(f"non-finite constant {x}")
    return repr(x)
