"""`--bind role=entity` and `--arg param=VALUE` of `rapidc run`.

VALUE is a constant expression in the language's own syntax: numbers with units (`90deg`, `10cm`),
vector literals (`[10cm, 0cm, 0cm]`), `+ - * /`, `^` with an integer exponent, unary minus,
parentheses and the constants `pi` and `up`. It must have the param's type and dimension exactly,
as a phase argument must (`--arg angle=90deg`, `--arg approach=-up`), and a finite value: every
number and every intermediate result is a 64-bit float, as in the checker (E0315). Values come out
in SI. Messages quote the given text with control and format characters escaped, shortened.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rapid_dsl.commands.common import shown
from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.types import BoolType, Quantity, Type, VecType
from rapid_dsl.language.units import DIMENSIONLESS, UNITS, Dim


class ArgumentProblem(ValueError):
    """A malformed --bind or --arg (the message says which and why)."""


@dataclass(frozen=True, slots=True)
class _Value:
    value: np.ndarray      # shape () for a quantity, (3,) for a vector; SI
    dim: Dim

    @property
    def is_vector(self) -> bool:
        return self.value.shape == (3,)


def split_pairs(items: Sequence[str], option: str) -> dict[str, str]:
    """`["a=b", ...]` -> {a: b}; a name given twice or a missing `=` is an error."""
    pairs: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise ArgumentProblem(f"{option} {shown(item)}: expected NAME=VALUE")
        if name in pairs:
            raise ArgumentProblem(f"{option} {shown(name)} is given twice")
        pairs[name] = value
    return pairs


def parse_arguments(items: Sequence[str], primitive: ir.Primitive) -> dict[str, object]:
    """--arg values for a primitive's params, as SI floats or (3,) tuples."""
    params = {p.name: p for p in primitive.params}
    values: dict[str, object] = {}
    for name, text in split_pairs(items, "--arg").items():
        param = params.get(name)
        if param is None:
            listed = ", ".join(params) or "none"
            raise ArgumentProblem(f"--arg {shown(name)}: `{primitive.name}` has no param "
                                  f"`{shown(name)}`; its params: {listed}")
        value = constant_value(text, f"--arg {name}")
        _check_type(value, param.type, name, text)
        values[name] = tuple(value.value.tolist()) if value.is_vector else float(value.value)
    return values


def constant_value(text: str, where: str) -> _Value:
    """Parse and fold a constant expression. Raises ArgumentProblem."""
    from rapid_dsl.frontend.parser import parse_expression

    node, diagnostics = parse_expression(text, where)
    errors = [d for d in diagnostics if d.is_error]
    if node is None or errors:
        message = errors[0].message if errors else "not an expression"
        raise ArgumentProblem(f"{where}={shown(text)}: {shown(message, 200)}")
    try:
        with np.errstate(all="ignore"):   # overflow becomes a message below, not a warning
            return _fold(node)
    except _NotConstant as exc:
        raise ArgumentProblem(f"{where}={shown(text)}: {exc}") from None


class _NotConstant(Exception):
    pass


# Keeps dimension exponents small; any base of at least 2 overflows a float before this anyway.
_MAX_EXPONENT = 1024


def _fold(node: ast.Expr) -> _Value:
    match node:
        case ast.Number(value=value, unit=unit, text=text):
            if not math.isfinite(value):
                raise _NotConstant(f"`{shown(text)}` is too large: numbers are 64-bit floats, at "
                                   "most about 1.8e308")
            if value == 0.0 and re.search("[1-9]", re.split("[eE]", text, maxsplit=1)[0]):
                raise _NotConstant(f"`{shown(text)}` is too small for a 64-bit float (it would "
                                   "be 0)")
            return _Value(np.array(float(value)), UNITS[unit][0] if unit else DIMENSIONLESS)
        case ast.Name(name="pi"):
            return _Value(np.array(math.pi), DIMENSIONLESS)
        case ast.Name(name="up"):
            return _Value(np.array([0.0, 0.0, 1.0]), DIMENSIONLESS)
        case ast.Vector(items=items):
            parts = [_fold(i) for i in items]
            if len(parts) != 3 or any(p.is_vector for p in parts):
                raise _NotConstant("a vector literal has three quantities")
            if len({p.dim for p in parts}) != 1:
                raise _NotConstant("the items of a vector need one dimension, e.g. "
                                   "`[10cm, 0cm, 0cm]`")
            return _Value(np.array([float(p.value) for p in parts]), parts[0].dim)
        case ast.Unary(op="-", operand=operand):
            inner = _fold(operand)
            return _Value(-inner.value, inner.dim)
        case ast.Binary(op=op, left=left, right=right):
            result = _binary(op, _fold(left), _fold(right))
            if not np.isfinite(result.value).all():
                raise _NotConstant(f"`{op}` here has no finite value (a number too large?)")
            return result
    raise _NotConstant("only constants are allowed here: numbers with units, vectors, "
                       "+ - * / ^, pi and up")


def _binary(op: str, a: _Value, b: _Value) -> _Value:
    if op in "+-":
        if a.dim != b.dim or a.is_vector != b.is_vector:
            verb = "add" if op == "+" else "subtract"
            raise _NotConstant(f"cannot {verb} {_describe(a)} and {_describe(b)}")
        return _Value(a.value + b.value if op == "+" else a.value - b.value, a.dim)
    if op == "^":
        if a.is_vector or b.is_vector or b.dim != DIMENSIONLESS \
                or not float(b.value).is_integer():
            raise _NotConstant("`^` takes a quantity and an integer exponent")
        power = int(b.value)
        if abs(power) > _MAX_EXPONENT:
            raise _NotConstant(f"the exponent of `^` is at most {_MAX_EXPONENT} in size")
        try:
            value = float(a.value) ** power
        except (OverflowError, ZeroDivisionError):   # 10^400, 0^-1: no float
            value = math.inf
        return _Value(np.array(value), a.dim ** power)
    if a.is_vector and b.is_vector:
        raise _NotConstant(f"cannot {'multiply' if op == '*' else 'divide'} two vectors")
    if op == "*":
        return _Value(a.value * b.value, a.dim * b.dim)
    if b.is_vector:
        raise _NotConstant("cannot divide by a vector")
    if float(b.value) == 0.0:
        raise _NotConstant("division by zero")
    return _Value(a.value / b.value, a.dim / b.dim)


def _describe(v: _Value) -> str:
    return str(VecType(v.dim)) if v.is_vector else str(Quantity(v.dim))


def _check_type(value: _Value, expected: Type, name: str, text: str) -> None:
    if isinstance(expected, BoolType):
        raise ArgumentProblem(f"--arg {name}: Bool params cannot be set from the command line")
    wanted_vector = isinstance(expected, VecType)
    wanted_dim = expected.dim if isinstance(expected, Quantity | VecType) else None
    if wanted_vector == value.is_vector and wanted_dim == value.dim:
        return
    got = _describe(value)
    hint = ""
    unit = _unit_hint(wanted_dim)
    if wanted_vector == value.is_vector and value.dim == DIMENSIONLESS and unit:
        hint = (f"; give each item a unit, e.g. `[10{unit}, 0{unit}, 0{unit}]`" if wanted_vector
                else f"; give it a unit, e.g. `{shown(text)}{unit}`")
    raise ArgumentProblem(f"--arg {name}={shown(text)}: `{name}` is a {expected}, got a "
                          f"{got}{hint}")


def _unit_hint(dim: Dim | None) -> str:
    for unit, (unit_dim, _) in UNITS.items():
        if unit_dim == dim and unit in ("cm", "deg", "kg", "s", "N"):
            return unit
    return ""
