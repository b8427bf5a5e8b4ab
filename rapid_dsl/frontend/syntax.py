"""The AST: what the user wrote, as frozen dataclasses with a source span on every node.

Spans do not take part in equality, so `parse(format(m)) == m` holds for round-trip tests.
Frozen, slotted dataclasses rather than pydantic models: the parser builds tens of thousands of
nodes per second and validation here would only repeat what the grammar already guarantees.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from rapid_dsl.frontend.tree import Node
from rapid_dsl.language.diagnostics import Span

NO_SPAN = Span("<none>", 0, 0, 0, 0, 0, 0)


def source_text(text: str) -> str:
    """Program text as every tool reads it (docs/language.md, section 1): a leading UTF-8 BOM
    dropped, and CRLF and a lone CR made LF, so all three end a line for `check` and `fmt` alike
    and lines and columns are the same in the parser, the formatter and the carets."""
    text = text.removeprefix("\ufeff")
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text


def _span() -> Span:
    return field(default=NO_SPAN, compare=False, repr=False)  # type: ignore[return-value]


# ----------------------------------------------------------------------------------- expressions

@dataclass(frozen=True, slots=True)
class Name(Node):
    name: str
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Number(Node):
    value: float            # in SI units (m, rad, kg, s, N)
    unit: str | None        # the suffix as written, `cm` in `3cm`
    text: str               # the literal as written, for messages and formatting
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Vector(Node):
    items: tuple[Expr, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Unary(Node):
    op: str                 # "-" | "not"
    operand: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Binary(Node):
    op: str                 # "+" | "-" | "*" | "/" | "^"
    left: Expr
    right: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Compare(Node):
    op: str                 # "<" | "<=" | ">" | ">=" | "==" | "!="
    left: Expr
    right: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Logic(Node):
    op: str                 # "and" | "or"
    left: Expr
    right: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class IfExpr(Node):
    cond: Expr
    then: Expr
    orelse: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Arg(Node):
    name: Name | None       # keyword, or None for a positional argument
    value: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Call(Node):
    func: Name
    args: tuple[Arg, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Component(Node):
    target: Expr
    field: Name             # only x, y, z are valid; the checker says so
    span: Span = _span()


Expr = Name | Number | Vector | Unary | Binary | Compare | Logic | IfExpr | Call | Component


# ------------------------------------------------------------------------------------------ types

@dataclass(frozen=True, slots=True)
class TypeName(Node):
    name: str
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class TypeApply(Node):
    name: str               # `Vec`
    arg: TypeExpr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class TypeBinary(Node):
    op: str                 # "*" | "/"
    left: TypeExpr
    right: TypeExpr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class TypePower(Node):
    base: TypeExpr
    exponent: int
    span: Span = _span()


TypeExpr = TypeName | TypeApply | TypeBinary | TypePower


# ------------------------------------------------------------------------------ shared pieces

@dataclass(frozen=True, slots=True)
class TypedName(Node):
    name: Name
    type: TypeExpr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Assign(Node):
    name: Name
    value: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Goal(Node):
    text: str
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Roles(Node):
    roles: tuple[TypedName, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Requires(Node):
    relations: tuple[Expr, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Success(Node):
    clauses: tuple[Expr, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Filter(Node):
    clauses: tuple[Expr, ...]
    span: Span = _span()


# ---------------------------------------------------------------------------------- primitives

@dataclass(frozen=True, slots=True)
class ParamDecl(Node):
    name: Name
    type: TypeExpr
    low: Expr | None = None
    high: Expr | None = None
    default: Expr | None = None
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Params(Node):
    params: tuple[ParamDecl, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Resolve(Node):
    features: tuple[Assign, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class CostFinal(Node):
    expr: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class CostProgress(Node):
    weight: Expr | None
    expr: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Keypoint(Node):
    name: Name
    point: Expr
    yaw: Expr | None = None
    pitch: Expr | None = None
    gripper: str | None = None      # "open" | "closed"
    span: Span = _span()
    roll: Expr | None = None        # about the hand's approach axis, after yaw and pitch


@dataclass(frozen=True, slots=True)
class MotionSetting(Node):
    key: str                        # "spread" | "spread_angle" | "duration"
    value: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Motion(Node):
    items: tuple[Keypoint | MotionSetting, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Setting(Node):
    name: Name
    value: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Optimize(Node):
    settings: tuple[Setting, ...]
    span: Span = _span()


PrimitiveBlock = (Goal | Roles | Requires | Params | Resolve | Success | CostFinal | CostProgress
                  | Motion | Optimize | Filter)


@dataclass(frozen=True, slots=True)
class Primitive(Node):
    name: Name
    blocks: tuple[PrimitiveBlock, ...]
    span: Span = _span()


# ---------------------------------------------------------------------------------- strategies

@dataclass(frozen=True, slots=True)
class Solve(Node):
    """`solve d: Point minimize OBJ subject { C1; C2 }` — a CasADi problem at the phase's start."""

    var: Name
    type: TypeExpr
    objective: Expr
    constraints: tuple[Expr, ...]
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class RoleBinding(Node):
    role: Name              # the primitive's role
    target: Name            # the strategy's role
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Argument(Node):
    name: Name
    value: Expr | Solve
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Let(Node):
    name: Name
    value: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Phase(Node):
    name: Name
    primitive: Name
    role_map: tuple[RoleBinding, ...]
    args: tuple[Argument, ...]
    span: Span = _span()
    on_fail: Name | None = None     # `on_fail continue`: the strategy goes on after a failure
    retry: Expr | None = None       # `retry 2`: a failed phase is tried up to 2 more times


StrategyBlock = Goal | Roles | Requires | Let | Phase | Success | Filter


@dataclass(frozen=True, slots=True)
class Strategy(Node):
    name: Name
    blocks: tuple[StrategyBlock, ...]
    span: Span = _span()


# -------------------------------------------------------------------------------- top level

@dataclass(frozen=True, slots=True)
class Use(Node):
    """`use stdlib.push`, `use stdlib.{push, flip}` or `use "lib/shelf.rapid"`."""

    module: tuple[str, ...] | None  # ("stdlib",) for stdlib names
    names: tuple[Name, ...]
    file: str | None = None
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class RelationDecl(Node):
    name: Name
    params: tuple[TypedName, ...]
    body: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class DefDecl(Node):
    name: Name
    params: tuple[TypedName, ...]
    returns: TypeExpr
    body: Expr
    span: Span = _span()


Decl = Use | RelationDecl | DefDecl | Primitive | Strategy


@dataclass(frozen=True, slots=True)
class Module(Node):
    path: str
    decls: tuple[Decl, ...]
    span: Span = _span()
