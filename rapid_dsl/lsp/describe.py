"""What hovers and completion items say: types with their dimensions, builtin signatures from the
registry, and the signatures of a program's own declarations as written.
"""

from __future__ import annotations

import re

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.formatter import format_expr, format_type
from rapid_dsl.frontend.types import BoolType, EntityType, ErrorType, Quantity, Type, VecType
from rapid_dsl.language.diagnostics import visible
from rapid_dsl.language.registry import Builtin
from rapid_dsl.language.units import si_unit

MAX_QUOTE = 60   # characters of an expression quoted in a hover
_PUNCTUATION = re.compile(r"[!-/:-@\[-`{-~]")   # ASCII punctuation, which Markdown may read


def type_text(t: Type) -> str:
    """`Length / Time (dimension of m/s)`: the type, and for values their dimension in SI."""
    match t:
        case Quantity(dim=dim):
            unit = si_unit(dim)
            return f"**{t}** (SI unit {unit})" if unit else f"**{t}** (dimensionless)"
        case VecType(dim=dim):
            unit = si_unit(dim)
            return (f"**{t}**, a vector of {Quantity(dim)} (SI unit {unit})" if unit
                    else f"**{t}**, a dimensionless vector")
        case EntityType():
            return f"**{t}**, an entity kind"
        case BoolType():
            return "**Bool**"
        case ErrorType():
            return "no type: the expression has an error"
    return f"**{t}**"


def code(text: str) -> str:
    """A fenced block of the language (editors highlight it with the grammar of editors/); no
    line of `text` can close it."""
    fence = "`" * max(3, max((len(run) for run in re.findall("`+", text)), default=0) + 1)
    return f"{fence}rapid\n{text}\n{fence}"


def quote(text: str) -> str:
    """Inline code for a piece of program text, shortened to one line. Program text is untrusted:
    inside a code span Markdown makes nothing of it (no link, no image to fetch)."""
    text = visible(" ".join(text.split()))
    if len(text) > MAX_QUOTE:
        text = text[:MAX_QUOTE - 3] + "..."
    if not text:
        return "this expression"
    ticks = "`" * (max((len(run) for run in re.findall("`+", text)), default=0) + 1)
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{ticks}{pad}{text}{pad}{ticks}"


def escape(text: str) -> str:
    """Untrusted text (a goal, a file name) as Markdown that shows it literally."""
    return _PUNCTUATION.sub(r"\\\g<0>", visible(" ".join(text.split())))


def builtin(b: Builtin) -> str:
    what = {"function": "builtin function", "relation": "builtin relation",
            "constant": "builtin constant"}[b.kind]
    return f"{code(b.signature)}\n\n{b.doc}\n\n*{what}*"


def typed_names(items: tuple[ast.TypedName, ...]) -> str:
    return ", ".join(f"{i.name.name}: {format_type(i.type)}" for i in items)


def param(p: ast.ParamDecl) -> str:
    text = f"{p.name.name}: {format_type(p.type)}"
    try:
        if p.low is not None and p.high is not None:
            text += f" in [{format_expr(p.low)}, {format_expr(p.high)}]"
        if p.default is not None:
            text += f" = {format_expr(p.default)}"
    except RecursionError:   # a bound nested thousands deep is an error the check reports
        text += " ..."
    return text


def block(decl: ast.Primitive | ast.Strategy, kind: type[ast.PrimitiveBlock | ast.StrategyBlock]
          ) -> ast.PrimitiveBlock | ast.StrategyBlock | None:
    return next((b for b in decl.blocks if isinstance(b, kind)), None)


def roles(decl: ast.Primitive | ast.Strategy) -> tuple[ast.TypedName, ...]:
    found = block(decl, ast.Roles)
    return found.roles if isinstance(found, ast.Roles) else ()


def params(decl: ast.Primitive) -> tuple[ast.ParamDecl, ...]:
    found = block(decl, ast.Params)
    return found.params if isinstance(found, ast.Params) else ()


def declaration(decl: ast.Decl, where: str | None = None) -> str:
    """A top-level declaration's signature, goal and params; `where` names its file if it is
    another one."""
    origin = f"\n\n*from {escape(where)}*" if where else ""
    match decl:
        case ast.DefDecl(name=name, params=ps, returns=returns):
            return code(f"def {name.name}({typed_names(ps)}) -> {format_type(returns)}") + origin
        case ast.RelationDecl(name=name, params=ps):
            return code(f"relation {name.name}({typed_names(ps)})") + origin
        case ast.Primitive() | ast.Strategy():
            keyword = "primitive" if isinstance(decl, ast.Primitive) else "strategy"
            lines = [f"{keyword} {decl.name.name}({typed_names(roles(decl))})"]
            if isinstance(decl, ast.Primitive):
                lines += [f"  param {param(p)}" for p in params(decl)]
            text = code("\n".join(lines))
            goal = block(decl, ast.Goal)
            if isinstance(goal, ast.Goal):
                text += f"\n\n{escape(goal.text)}"
            return text + origin
    return ""
