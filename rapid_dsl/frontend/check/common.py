"""Pieces shared by the primitive, strategy and function checkers: blocks, local names, roles,
clauses and constants.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TypeVar

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.check.expressions import ExprChecker, is_error
from rapid_dsl.frontend.check.fold import Value, fold
from rapid_dsl.frontend.check.scope import Env, Hidden, Local
from rapid_dsl.frontend.check.signatures import resolve_type
from rapid_dsl.frontend.check.text import snippet
from rapid_dsl.frontend.ir import RefKind
from rapid_dsl.frontend.types import ERROR, EntityType, Quantity, Type, VecType
from rapid_dsl.language.diagnostics import Diagnostic, Span, error
from rapid_dsl.language.kinds import KIND_PARENTS
from rapid_dsl.language.registry import BUILTINS

BLOCK_NAMES: dict[type, str] = {
    ast.Goal: "goal", ast.Roles: "roles", ast.Requires: "requires", ast.Params: "params",
    ast.Resolve: "resolve", ast.Success: "success", ast.CostFinal: "cost final",
    ast.CostProgress: "cost progress", ast.Motion: "motion", ast.Optimize: "optimize",
    ast.Filter: "filter",
}
KIND_LIST = ", ".join(KIND_PARENTS)
B = TypeVar("B")


@dataclass(slots=True)
class Names:
    """The local names of one declaration (one scope: roles, params, features, lets, ...)."""

    diagnostics: list[Diagnostic]
    seen: dict[str, tuple[str, Span]] = field(default_factory=dict)

    def declare(self, name: ast.Name, what: str) -> bool:
        """Record a name; report and return False when it is taken or reserved."""
        builtin = BUILTINS.get(name.name)
        if builtin is not None and builtin.kind == "constant":
            self.diagnostics.append(error(
                "E0215", f"`{name.name}` is a builtin constant and cannot name a {what}",
                name.span, help="choose another name"))
            return False
        if name.name == "start":
            self.diagnostics.append(error(
                "E0215", f"`start` is a special form and cannot name a {what}", name.span,
                help="choose another name"))
            return False
        previous = self.seen.get(name.name)
        if previous is not None:
            self.diagnostics.append(error(
                "E0202", f"`{name.name}` is already declared as a {previous[0]}", name.span,
                related=[("first declared", previous[1])],
                help="names are unique within a primitive, strategy, relation or def"))
            return False
        self.seen[name.name] = (what, name.span)
        return True


class Blocks:
    """The blocks of one declaration, the first of each kind; repeats are reported (E0402)."""

    def __init__(self, blocks: tuple[ast.PrimitiveBlock | ast.StrategyBlock, ...],
                 diagnostics: list[Diagnostic]) -> None:
        self.found: dict[type, ast.PrimitiveBlock | ast.StrategyBlock] = {}
        for block in blocks:
            kind = type(block)
            if kind is ast.Let or kind is ast.Phase:
                continue
            first = self.found.get(kind)
            if first is not None:
                diagnostics.append(error(
                    "E0402", f"`{BLOCK_NAMES[kind]}` is given twice", _first_line(block.span),
                    related=[("first given", _first_line(first.span))],
                    help="merge the two blocks into one"))
                continue
            self.found[kind] = block

    def get(self, kind: type[B]) -> B | None:
        block = self.found.get(kind)
        return block if isinstance(block, kind) else None

    def __contains__(self, kind: type) -> bool:
        return kind in self.found


def _first_line(span: Span) -> Span:
    """A block's span cut to its first line, so carets stay short."""
    if span.end_line == span.line:
        return span
    return Span(span.path, span.start, span.start, span.line, span.col, span.line, span.col + 1)


def keyword_span(span: Span, keyword: str) -> Span:
    """The span of the block's leading keyword (`success`, `motion`, ...)."""
    return Span(span.path, span.start, span.start + len(keyword), span.line, span.col, span.line,
                span.col + len(keyword))


def check_roles(roles: ast.Roles | None, names: Names,
                diagnostics: list[Diagnostic]) -> list[ir.Role]:
    out: list[ir.Role] = []
    for item in roles.roles if roles else ():
        t = resolve_type(item.type, diagnostics)
        if not isinstance(t, EntityType):
            if t is not ERROR:
                diagnostics.append(error(
                    "E0316", f"a role's type is an entity kind, not {t}", item.type.span,
                    help=f"entity kinds are {KIND_LIST}; values belong in `params`"))
            t = EntityType("Body")
            if not names.declare(item.name, "role"):
                continue
            out.append(ir.Role(item.name.name, "<error>", item.span))
            continue
        if names.declare(item.name, "role"):
            out.append(ir.Role(item.name.name, t.kind, item.span))
    return out


def role_locals(roles: list[ir.Role]) -> list[Local]:
    return [Local("role", r.name, EntityType(r.kind) if r.kind in KIND_PARENTS else ERROR,
                  r.span) for r in roles]


def value_type(t: Type) -> bool:
    return isinstance(t, (Quantity, VecType))


def clause(expr: ir.Expr, node: ast.Expr, text: str) -> ir.Clause:
    return ir.Clause(expr, snippet(text, node.span), node.span)


def check_clauses(exprs: ExprChecker, nodes: tuple[ast.Expr, ...], env: Env, what: str,
                  text: str) -> tuple[ir.Clause, ...]:
    return tuple(clause(exprs.check_bool(n, env, what), n, text) for n in nodes)


def constant(exprs: ExprChecker, node: ast.Expr, env: Env, expected: Type, what: str
             ) -> tuple[ir.Expr, Value | None]:
    """Check a constant of type `expected`: (the expression, its value or None on error)."""
    expr = exprs.check(node, env)
    if is_error(expr.type):
        return expr, None
    if expr.type != expected:
        hint = exprs.unit_help(node, node, expected, expected, "give it a unit") \
            if isinstance(expected, (Quantity, VecType)) else None
        exprs.err("E0313", f"{what} must be {_a(str(expected))}, got {expr.type}", node.span,
                  help=hint)
        return expr, None
    value = fold(expr)
    if value is None:
        exprs.err("E0314", f"{what} must be a constant", node.span,
                  help="use numbers with units and arithmetic, e.g. `2 * 3cm`")
    return expr, value


def constant_env(env: Env, names: dict[str, tuple[str, Span]], what: str) -> Env:
    """An environment where every local name is hidden: for ranges, defaults and settings."""
    return Env(env.globals, {}, _NotConstant(names, what), False, None)


class _NotConstant(Mapping[str, Hidden]):
    """Every local name of a declaration, hidden where only constants may appear. Entries are
    made on lookup: a declaration with n params must not build n tables of n names."""

    __slots__ = ("names", "what")

    def __init__(self, names: Mapping[str, tuple[str, Span]], what: str) -> None:
        self.names = names
        self.what = what

    def __getitem__(self, name: str) -> Hidden:
        kind = self.names[name][0]
        return Hidden("E0314", f"{self.what} must be a constant, but `{name}` is a {kind}",
                      "use numbers with units, e.g. `2cm`")

    def __iter__(self) -> Iterator[str]:
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)


class Ahead:
    """The names of a run of definitions (resolve entries, keypoints, lets) not yet checked:
    each stays hidden until its own definition has been checked (so it cannot use itself). One
    live table for the whole run: n definitions cost O(n), not O(n^2)."""

    def __init__(self, names: list[str], hidden: Callable[[str], Hidden]) -> None:
        self.remaining = Counter(names)
        self.hidden: dict[str, Hidden] = {n: hidden(n) for n in self.remaining}

    def passed(self, name: str) -> None:
        self.remaining[name] -= 1
        if not self.remaining[name]:
            self.hidden.pop(name, None)


def hide(names: dict[str, tuple[str, Span]], code: str, message: str, help: str | None,
         only: set[str] | None = None) -> dict[str, Hidden]:
    return {n: Hidden(code, message.format(name=n, kind=kind), help)
            for n, (kind, _) in names.items() if only is None or kind in only}


def local(kind: RefKind, name: ast.Name, t: Type) -> Local:
    return Local(kind, name.name, t, name.span)


def _a(text: str) -> str:
    return ("an " if text[:1] in "AEIOU" else "a ") + text


def format_value(value: Value, t: Type) -> str:
    """A folded constant in the unit a person would write: 0.349 rad -> `20deg`."""
    import math
    if isinstance(value, bool) or isinstance(value, tuple) or not isinstance(t, Quantity):
        return str(value)
    unit = {(1, 0, 0, 0): ("cm", 100.0), (0, 1, 0, 0): ("deg", 180.0 / math.pi),
            (0, 0, 0, 1): ("s", 1.0), (0, 0, 1, 0): ("kg", 1.0)}.get(t.dim.exponents)
    if unit is None:
        return f"{value:.6g}"
    return f"{value * unit[1]:.6g}{unit[0]}"
