"""The typed IR: what the checker proved about a program, and all the compiler reads.

Names are resolved (a `Ref` knows whether it is a role, a param, a resolved feature, ...), keyword
arguments are put in declaration order, units are folded into SI constants, and every expression
carries its type. Spans are kept so generated code and run-time reports point back to `.rapid`
lines.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from rapid_dsl.frontend.syntax import NO_SPAN
from rapid_dsl.frontend.tree import Node
from rapid_dsl.frontend.types import Type
from rapid_dsl.language.diagnostics import Span


def _span() -> Span:
    return field(default=NO_SPAN, compare=False, repr=False)  # type: ignore[return-value]


RefKind = Literal["role", "param", "feature", "let", "keypoint", "local", "solve_var"]


@dataclass(frozen=True, slots=True)
class Const(Node):
    value: float | tuple[float, float, float] | bool
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Ref(Node):
    kind: RefKind           # `local` is a parameter of a `def` or `relation`
    name: str
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class BuiltinCall(Node):
    name: str               # a key of rapid_dsl.language.registry.BUILTINS
    args: tuple[Expr, ...]  # in the builtin's parameter order
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class UserCall(Node):
    name: str               # a `def` or `relation` of the program
    args: tuple[Expr, ...]
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Unary(Node):
    op: Literal["-", "not"]
    operand: Expr
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Binary(Node):
    op: Literal["+", "-", "*", "/", "^"]   # for "^" the right side is an integer Const
    left: Expr
    right: Expr
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Compare(Node):
    op: Literal["<", "<=", ">", ">=", "==", "!="]
    left: Expr
    right: Expr
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Logic(Node):
    op: Literal["and", "or"]
    left: Expr
    right: Expr
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class If(Node):
    cond: Expr
    then: Expr
    orelse: Expr
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Vector(Node):
    items: tuple[Expr, Expr, Expr]
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Component(Node):
    target: Expr
    index: int              # 0, 1, 2 for .x, .y, .z
    type: Type
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Start(Node):
    """`start(e)`: e evaluated at the running primitive's first step."""

    expr: Expr
    type: Type
    span: Span = _span()


Expr = Const | Ref | BuiltinCall | UserCall | Unary | Binary | Compare | Logic | If | Vector \
    | Component | Start


@dataclass(frozen=True, slots=True)
class Solve(Node):
    """`solve var: T minimize objective subject {constraints}` for one phase argument."""

    var: str
    var_type: Type
    objective: Expr
    constraints: tuple[Expr, ...]   # each a Compare; only Ref(kind="solve_var") is symbolic
    type: Type
    span: Span = _span()


# ------------------------------------------------------------------------------- declarations

@dataclass(frozen=True, slots=True)
class Role(Node):
    name: str
    kind: str               # Body | Object | Fixture | Surface | Manipulator
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Clause(Node):
    """A success, requires or filter line, with its source text for reports."""

    expr: Expr
    text: str
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Param(Node):
    name: str
    type: Type
    low: float | None = None          # SI, inclusive
    high: float | None = None
    default: Expr | None = None
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Feature(Node):
    name: str
    expr: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Keypoint(Node):
    name: str
    point: Expr
    yaw: Expr | None
    pitch: Expr | None
    roll: Expr | None
    gripper: Literal["open", "closed"] | None
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class OptimizeSettings(Node):
    samples: int = 64
    elites: int = 8
    iterations: int = 6
    seed: int | None = None
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Primitive(Node):
    name: str
    goal: str
    roles: tuple[Role, ...]
    requires: tuple[Clause, ...]
    params: tuple[Param, ...]
    features: tuple[Feature, ...]       # resolve entries, in order
    success: tuple[Clause, ...]
    cost_final: Expr
    cost_progress: Expr | None
    progress_weight: float
    keypoints: tuple[Keypoint, ...]
    spread: float                       # m
    spread_angle: float                 # rad
    duration: float                     # s
    optimize: OptimizeSettings
    filter: tuple[Clause, ...]
    path: str                           # file that declares it
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Let(Node):
    name: str
    expr: Expr
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Argument(Node):
    param: str
    value: Expr | Solve
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Phase(Node):
    name: str
    primitive: str
    role_map: tuple[tuple[str, str], ...]       # (primitive role, strategy role)
    args: tuple[Argument, ...]                  # one per param without default, plus overrides
    unchecked_requires: tuple[Clause, ...]      # primitive requires the strategy does not state
    span: Span = _span()
    on_fail: str = "stop"                       # "continue": the strategy goes on after a failure
    retry: int = 0                              # further attempts after a failed one


@dataclass(frozen=True, slots=True)
class Strategy(Node):
    name: str
    goal: str
    roles: tuple[Role, ...]
    requires: tuple[Clause, ...]
    lets: tuple[Let, ...]
    phases: tuple[Phase, ...]
    success: tuple[Clause, ...]
    filter: tuple[Clause, ...]
    path: str
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Function(Node):
    """A `def` (returns a value) or a `relation` (returns Bool) declared in a program."""

    name: str
    params: tuple[tuple[str, Type], ...]
    returns: Type
    body: Expr
    is_relation: bool
    span: Span = _span()


@dataclass(frozen=True, slots=True)
class Program(Node):
    """Everything a file can run: its own declarations and what it brings in with `use`."""

    path: str
    functions: tuple[Function, ...]
    primitives: tuple[Primitive, ...]
    strategies: tuple[Strategy, ...]
    own: tuple[str, ...]            # names declared in the file itself, in source order

    def primitive(self, name: str) -> Primitive:
        return next(p for p in self.primitives if p.name == name)

    def strategy(self, name: str) -> Strategy:
        return next(s for s in self.strategies if s.name == name)
