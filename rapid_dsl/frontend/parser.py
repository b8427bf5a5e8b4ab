"""Text to AST, with the grammar's LALR tables (lark builds them once: frontend/parser_tables.py)
run by rapid_dsl/frontend/lalr.py, which calls the builder below at each reduction.

`parse_module` never raises on bad input: it returns the module (or None) and the diagnostics.
A syntax error stops LALR parsing, so on failure each top-level declaration is parsed again on its
own; one broken declaration then does not hide the errors of the others.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from dataclasses import replace
from functools import cache, lru_cache
from importlib import resources
from typing import Any

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.lalr import (
    Parser,
    Token,
    UnexpectedCharacters,
    UnexpectedInput,
    UnexpectedToken,
)
from rapid_dsl.frontend.parser_tables import load_parser
from rapid_dsl.language.diagnostics import Diagnostic, Span, error
from rapid_dsl.language.units import UNITS

MAX_NESTING = 100  # brackets deeper than this are refused: nobody writes them, and they cost stack
# Levels of one expression (a name or number is one, each operator, call, component, vector or
# `if` around it one more); real programs stay below 20. The parser refuses deeper ones as it
# reads them, so the checker, the formatter and the compiler, which recurse once per level,
# never meet one.
MAX_DEPTH = 400

_CONTINUATION_TEXT = {"{", "(", "[", ",", "=", "+", "-", "*", "/", "^", "<", ">", "<=", ">=", "==",
                      "!=", "and", "or", "not", "then", "else", "if", "->", ":", "."}
_OPENERS = {"{": "}", "(": ")", "[": "]"}


START = ["start", "expr_only", "type_only"]


@cache
def _runtime() -> Parser:
    """The parser, its tables built once per grammar and cached (frontend/parser_tables.py)."""
    grammar = resources.files("rapid_dsl.grammar").joinpath("rapid.lark").read_text("utf-8")
    return load_parser(grammar, START, _Newlines.always_accept)


@cache
def _terminal_text() -> dict[str, str]:
    """Terminal name -> the literal it matches, for the ones that are literals."""
    return dict(_runtime().literals)


class _Newlines:
    """Makes newlines significant only where they end a statement (see grammar/rapid.lark)."""

    always_accept: tuple[str, ...] = ("_NL",)

    def __init__(self) -> None:
        self.open_brackets: list[Token] = []

    def process(self, stream: Iterator[Token]) -> Iterator[Token]:
        texts = _terminal_text()
        continuation = {name for name, text in texts.items() if text in _CONTINUATION_TEXT}
        self.open_brackets = []
        previous: str | None = None
        for tok in stream:
            if tok.type == "_NL":
                inside_parens = self.open_brackets and self.open_brackets[-1].value in "(["
                if previous in (None, "_NL") or (
                        tok.value != ";" and (inside_parens or previous in continuation)):
                    continue
            text = texts.get(tok.type)
            if text in _OPENERS:
                self.open_brackets.append(tok)
                if len(self.open_brackets) > MAX_NESTING:
                    raise _TooDeep(tok)
            elif text in (")", "]", "}") and self.open_brackets:
                self.open_brackets.pop()
            previous = tok.type
            yield tok


class _TooDeep(Exception):
    def __init__(self, token: Token) -> None:
        self.token = token


class _TooDeepExpression(Exception):
    """An expression nests deeper than MAX_DEPTH: `span` is where it starts."""

    def __init__(self, span: Span) -> None:
        self.span = span


# -------------------------------------------------------------------------------- AST builder

_UNIT_SPLIT = re.compile(r"^((?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)(.*)$")
_ESCAPE = re.compile(r"\\(.)")


class _Builder:
    """Parse tree -> frontend.syntax, one method per grammar rule, called by the parser at each
    reduction (bottom-up, without recursion) with the node's `meta` (positions) and its already
    built children."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.diagnostics: list[Diagnostic] = []
        self.parenthesized: dict[int, Span] = {}
        self.depths: dict[int, int] = {}   # id -> levels, of each expression node but the leaves

    # spans ---------------------------------------------------------------------------------
    def span(self, meta: Any) -> Span:
        if getattr(meta, "empty", True):
            return Span.point(self.path)
        return Span(self.path, meta.start_pos, meta.end_pos, meta.line, meta.column,
                    meta.end_line, meta.end_column)

    def tspan(self, tok: Token) -> Span:
        return _token_span(self.path, tok)

    def ident(self, tok: Token) -> ast.Name:
        return ast.Name(str(tok), self.tspan(tok))

    # depth ---------------------------------------------------------------------------------
    def depth(self, node: Any) -> int:
        if isinstance(node, (ast.Name, ast.Number)):
            return 1
        return self.depths[id(node)]   # every other node was built through `nested`

    def nested(self, node: Any, children: Iterable[Any], *, within: int = 0,
               start: Span | None = None) -> Any:
        """`node` (of these children), its depth recorded. Under `within` more levels that are
        sure to come (operators of a chain still waiting for their operand) it must still fit
        in MAX_DEPTH, or the parse stops here: at `start`, where the deep expression starts."""
        depth = 1 + max(map(self.depth, children), default=0)
        if depth + within > MAX_DEPTH:
            raise _TooDeepExpression(start or node.span)
        self.depths[id(node)] = depth
        return node

    # top level -----------------------------------------------------------------------------
    def start(self, meta: Any, decls: list[Any]) -> ast.Module:
        return ast.Module(self.path, tuple(decls), self.span(meta))

    def expr_only(self, meta: Any, children: list[Any]) -> Any:
        return children[0]

    def type_only(self, meta: Any, children: list[Any]) -> Any:
        return children[0]

    def module_path(self, meta: Any, children: list[Any]) -> list[Token]:
        return [tok for child in children
                for tok in (child if isinstance(child, list) else [child])]

    def use_one(self, meta: Any, children: list[Any]) -> ast.Use:
        path: list[Token] = children[0]
        span = self.span(meta)
        if len(path) < 2:
            self.diagnostics.append(error(
                "E0108", f"`use {path[0]}` names a module but no declaration", span,
                help=f"write `use stdlib.{path[0]}` or `use \"{path[0]}.rapid\"`"))
        return ast.Use(tuple(map(str, path[:-1])), (self.ident(path[-1]),), None, span)

    def use_many(self, meta: Any, children: list[Any]) -> ast.Use:
        path, names = children
        return ast.Use(tuple(map(str, path)), tuple(names), None, self.span(meta))

    def name_list(self, meta: Any, children: list[Token]) -> list[ast.Name]:
        return [self.ident(tok) for tok in children]

    def use_file(self, meta: Any, children: list[Token]) -> ast.Use:
        return ast.Use(None, (), self.string(children[0]), self.span(meta))

    def relation_decl(self, meta: Any, children: list[Any]) -> ast.RelationDecl:
        name, *rest = children
        params = rest[0] if len(rest) == 2 else []
        return ast.RelationDecl(self.ident(name), tuple(params), rest[-1], self.span(meta))

    def def_decl(self, meta: Any, children: list[Any]) -> ast.DefDecl:
        name, *rest = children
        params = rest[0] if len(rest) == 3 else []
        return ast.DefDecl(self.ident(name), tuple(params), rest[-2], rest[-1], self.span(meta))

    def typed_names(self, meta: Any, children: list[ast.TypedName]) -> list[ast.TypedName]:
        return children

    def typed_name(self, meta: Any, children: list[Any]) -> ast.TypedName:
        return ast.TypedName(self.ident(children[0]), children[1], self.span(meta))

    def primitive(self, meta: Any, children: list[Any]) -> ast.Primitive:
        return ast.Primitive(self.ident(children[0]), tuple(children[1:]), self.span(meta))

    def strategy(self, meta: Any, children: list[Any]) -> ast.Strategy:
        return ast.Strategy(self.ident(children[0]), tuple(children[1:]), self.span(meta))

    # blocks --------------------------------------------------------------------------------
    def goal(self, meta: Any, children: list[Token]) -> ast.Goal:
        return ast.Goal(self.string(children[0]), self.span(meta))

    def roles(self, meta: Any, children: list[ast.TypedName]) -> ast.Roles:
        return ast.Roles(tuple(children), self.span(meta))

    def expr_lines(self, meta: Any, children: list[Any]) -> list[Any]:
        return children

    def _lines(self, children: list[Any]) -> tuple[Any, ...]:
        return tuple(children[0]) if children else ()

    def requires(self, meta: Any, children: list[Any]) -> ast.Requires:
        return ast.Requires(self._lines(children), self.span(meta))

    def success(self, meta: Any, children: list[Any]) -> ast.Success:
        return ast.Success(self._lines(children), self.span(meta))

    def filter(self, meta: Any, children: list[Any]) -> ast.Filter:
        return ast.Filter(self._lines(children), self.span(meta))

    def params(self, meta: Any, children: list[ast.ParamDecl]) -> ast.Params:
        return ast.Params(tuple(children), self.span(meta))

    def param(self, meta: Any, children: list[Any]) -> ast.ParamDecl:
        name, type_, *rest = children
        low = high = default = None
        for item in rest:
            if isinstance(item, tuple):
                low, high = item
            else:
                default = item.default
        return ast.ParamDecl(self.ident(name), type_, low, high, default, self.span(meta))

    def param_range(self, meta: Any, children: list[Any]) -> tuple[Any, Any]:
        return (children[0], children[1])

    def param_default(self, meta: Any, children: list[Any]) -> Any:
        return _Default(children[0])

    def resolve(self, meta: Any, children: list[ast.Assign]) -> ast.Resolve:
        return ast.Resolve(tuple(children), self.span(meta))

    def assign(self, meta: Any, children: list[Any]) -> ast.Assign:
        return ast.Assign(self.ident(children[0]), children[1], self.span(meta))

    def cost_final(self, meta: Any, children: list[Any]) -> ast.CostFinal:
        return ast.CostFinal(children[0], self.span(meta))

    def cost_progress(self, meta: Any, children: list[Any]) -> ast.CostProgress:
        weight = children[0].weight if len(children) == 2 else None
        return ast.CostProgress(weight, children[-1], self.span(meta))

    def cost_weight(self, meta: Any, children: list[Any]) -> Any:
        return _Weight(children[0])

    def motion(self, meta: Any, children: list[Any]) -> ast.Motion:
        return ast.Motion(tuple(children), self.span(meta))

    def keypoint(self, meta: Any, children: list[Any]) -> ast.Keypoint:
        name, point, *options = children
        found: dict[str, Any] = {}
        for key, value, span in options:
            if key in found:
                self.diagnostics.append(error(
                    "E0109", f"keypoint `{name}` sets `{key}` twice", span,
                    help=f"keep one `{key}` option"))
            found[key] = value
        return ast.Keypoint(self.ident(name), point, found.get("yaw"), found.get("pitch"),
                            found.get("gripper"), self.span(meta), found.get("roll"))

    def kp_yaw(self, meta: Any, children: list[Any]) -> tuple[str, Any, Span]:
        return ("yaw", children[0], self.span(meta))

    def kp_pitch(self, meta: Any, children: list[Any]) -> tuple[str, Any, Span]:
        return ("pitch", children[0], self.span(meta))

    def kp_roll(self, meta: Any, children: list[Any]) -> tuple[str, Any, Span]:
        return ("roll", children[0], self.span(meta))

    def kp_open(self, meta: Any, children: list[Any]) -> tuple[str, Any, Span]:
        return ("gripper", "open", self.span(meta))

    def kp_closed(self, meta: Any, children: list[Any]) -> tuple[str, Any, Span]:
        return ("gripper", "closed", self.span(meta))

    def _motion_setting(self, key: str, meta: Any, children: list[Any]) -> ast.MotionSetting:
        return ast.MotionSetting(key, children[0], self.span(meta))

    def spread(self, meta: Any, children: list[Any]) -> ast.MotionSetting:
        return self._motion_setting("spread", meta, children)

    def spread_angle(self, meta: Any, children: list[Any]) -> ast.MotionSetting:
        return self._motion_setting("spread_angle", meta, children)

    def duration(self, meta: Any, children: list[Any]) -> ast.MotionSetting:
        return self._motion_setting("duration", meta, children)

    def optimize(self, meta: Any, children: list[ast.Setting]) -> ast.Optimize:
        return ast.Optimize(tuple(children), self.span(meta))

    def setting(self, meta: Any, children: list[Any]) -> ast.Setting:
        return ast.Setting(self.ident(children[0]), children[1], self.span(meta))

    def let(self, meta: Any, children: list[Any]) -> ast.Let:
        return ast.Let(self.ident(children[0]), children[1], self.span(meta))

    def phase(self, meta: Any, children: list[Any]) -> ast.Phase:
        name, primitive, *rest = children
        role_map: list[ast.RoleBinding] = []
        args: list[ast.Argument] = []
        on_fail = None
        retry = None
        for item in rest:
            if isinstance(item, _RoleMap):
                role_map = item.bindings
            elif isinstance(item, ast.Name):
                on_fail = item
            elif isinstance(item, _Retry):
                retry = item.count
            else:
                args = item.args
        return ast.Phase(self.ident(name), self.ident(primitive), tuple(role_map), tuple(args),
                         self.span(meta), on_fail, retry)

    def on_fail(self, meta: Any, children: list[Token]) -> ast.Name:
        return self.ident(children[0])

    def retry(self, meta: Any, children: list[Any]) -> Any:
        return _Retry(children[0])

    def role_map(self, meta: Any, children: list[ast.RoleBinding]) -> Any:
        return _RoleMap(children)

    def role_binding(self, meta: Any, children: list[Token]) -> ast.RoleBinding:
        return ast.RoleBinding(self.ident(children[0]), self.ident(children[1]), self.span(meta))

    def phase_args(self, meta: Any, children: list[ast.Argument]) -> Any:
        return _PhaseArgs(children)

    def argument(self, meta: Any, children: list[Any]) -> ast.Argument:
        return ast.Argument(self.ident(children[0]), children[1], self.span(meta))

    solve_argument = argument

    def solve(self, meta: Any, children: list[Any]) -> ast.Solve:
        var, type_, objective, *rest = children
        constraints = tuple(rest[0]) if rest else ()
        return ast.Solve(self.ident(var), type_, objective, constraints, self.span(meta))

    # types ---------------------------------------------------------------------------------
    def type_name(self, meta: Any, children: list[Token]) -> ast.TypeName:
        return ast.TypeName(str(children[0]), self.span(meta))

    def type_apply(self, meta: Any, children: list[Any]) -> ast.TypeApply:
        return ast.TypeApply(str(children[0]), children[1], self.span(meta))

    def type_mul(self, meta: Any, children: list[Any]) -> ast.TypeBinary:
        return ast.TypeBinary("*", children[0], children[1], self.span(meta))

    def type_div(self, meta: Any, children: list[Any]) -> ast.TypeBinary:
        return ast.TypeBinary("/", children[0], children[1], self.span(meta))

    def type_pow(self, meta: Any, children: list[Any]) -> ast.TypePower:
        return ast.TypePower(children[0], int(children[1]), self.span(meta))

    # expressions ---------------------------------------------------------------------------
    def if_expr(self, meta: Any, children: list[Any]) -> ast.IfExpr:
        return self.nested(ast.IfExpr(children[0], children[1], children[2], self.span(meta)),
                           children)

    def paren(self, meta: Any, children: list[Any]) -> Any:
        # No node of its own. The expression keeps its span (diagnostics underline what is inside
        # the parentheses); an operator chain around it spans the parentheses too.
        self.parenthesized[id(children[0])] = self.span(meta)
        return children[0]

    def outer_span(self, node: Any) -> Span:
        return self.parenthesized.get(id(node), node.span)

    # an operator chain, fed to `_Chain` item by item as the parser reads it
    def chain_start(self, meta: Any, children: list[Any]) -> _Chain:
        chain = _Chain(self)
        for item in children:
            chain.add(item)
        return chain

    def chain_more(self, meta: Any, children: list[Any]) -> _Chain:
        chain, item = children
        chain.add(item)
        return chain

    chain_closed = chain_more

    def ops(self, meta: Any, children: list[_Chain]) -> Any:
        return children[0].finish()

    @staticmethod  # a factory used in the class body below
    def _operator(symbol: str) -> Any:
        def method(self: _Builder, meta: Any, children: list[Any]) -> _Operator:
            return _Operator(symbol, self.span(meta))
        return method

    op_or, op_and = _operator("or"), _operator("and")
    op_lt, op_le, op_gt, op_ge = _operator("<"), _operator("<="), _operator(">"), _operator(">=")
    op_eq, op_ne = _operator("=="), _operator("!=")
    op_add, op_sub, op_mul = _operator("+"), _operator("-"), _operator("*")
    op_div, op_pow = _operator("/"), _operator("^")
    prefix_neg, prefix_not = _operator("-"), _operator("not")

    def component(self, meta: Any, children: list[Any]) -> ast.Component:
        return self.nested(ast.Component(children[0], self.ident(children[1]), self.span(meta)),
                           children[:1])

    def call(self, meta: Any, children: list[Any]) -> ast.Call:
        args: tuple[ast.Arg, ...] = tuple(children[1]) if len(children) > 1 else ()
        return self.nested(ast.Call(self.ident(children[0]), args, self.span(meta)),
                           [a.value for a in args])

    def call_args(self, meta: Any, children: list[ast.Arg]) -> list[ast.Arg]:
        return children

    def positional(self, meta: Any, children: list[Any]) -> ast.Arg:
        return ast.Arg(None, children[0], self.span(meta))

    def keyword(self, meta: Any, children: list[Any]) -> ast.Arg:
        return ast.Arg(self.ident(children[0]), children[1], self.span(meta))

    def name(self, meta: Any, children: list[Token]) -> ast.Name:
        return ast.Name(str(children[0]), self.span(meta))

    def vector(self, meta: Any, children: list[Any]) -> ast.Vector:
        return self.nested(ast.Vector(tuple(children), self.span(meta)), children)

    def number(self, meta: Any, children: list[Token]) -> ast.Number:
        text = str(children[0])
        span = self.span(meta)
        match = _UNIT_SPLIT.match(text)
        assert match, text  # the NUMBER terminal guarantees this shape
        digits, unit = match.group(1), match.group(2) or None
        value = float(digits)
        if unit is not None:
            if unit in UNITS:
                value *= UNITS[unit][1]
            else:
                self.diagnostics.append(error(
                    "E0105", f"unknown unit `{unit}` in `{text}`", span,
                    label="not a unit", help="units are " + ", ".join(f"`{u}`" for u in UNITS)))
        return ast.Number(value, unit, text, span)

    # literals ------------------------------------------------------------------------------
    def string(self, tok: Token) -> str:
        body = str(tok)[1:-1]

        def unescape(m: re.Match[str]) -> str:
            if m.group(1) not in "\"\\":
                self.diagnostics.append(error(
                    "E0106", f"unknown escape `\\{m.group(1)}` in a string", self.tspan(tok),
                    help='strings know only `\\"` and `\\\\`'))
            return m.group(1)
        return _ESCAPE.sub(unescape, body)


class _Operator:
    """An operator token of a chain, before precedence gives it its operands."""

    __slots__ = ("symbol", "span")

    def __init__(self, symbol: str, span: Span) -> None:
        self.symbol = symbol
        self.span = span


_COMPARISONS = {"<", "<=", ">", ">=", "==", "!="}
# symbol -> (left binding power, right binding power); higher binds tighter.
_BINARY = {"or": (1, 2), "and": (3, 4), **{op: (7, 8) for op in _COMPARISONS},
           "+": (9, 10), "-": (9, 10), "*": (11, 12), "/": (11, 12), "^": (16, 15)}
_PREFIX = {"not": 5, "-": 13}  # right binding power of the prefix operators


class _Frame:
    """One level of a chain being read: `pending` waits for its right operand (a prefix
    operator, or a binary one whose left operand is `left`), binding operators of at least
    `min_power`; without `pending`, `left` is the level's value so far."""

    __slots__ = ("min_power", "left", "pending")

    def __init__(self, min_power: int) -> None:
        self.min_power = min_power
        self.left: Any = None
        self.pending: _Operator | None = None


class _Chain:
    """Precedence parsing of a chain `[-] a op [not] b op c ...` into nested AST nodes, item by
    item as the parser reads them (the stack of `_Frame`s is what Pratt parsing would keep on
    Python's stack). Nothing recurses, and a chain that is sure to nest deeper than MAX_DEPTH,
    such as a long run of `-` or of `+`, stops the parse as it is."""

    def __init__(self, builder: _Builder) -> None:
        self.builder = builder
        self.frames = [_Frame(0)]
        self.start: Span | None = None     # where the chain starts

    def add(self, item: Any) -> None:
        if self.start is None:
            self.start = item.span if isinstance(item, _Operator) else \
                self.builder.outer_span(item)
        top = self.frames[-1]
        if top.pending is None and top.left is not None:   # a binary operator
            left_power, right_power = _BINARY[item.symbol]
            while left_power < top.min_power:
                self.reduce(item)
                top = self.frames[-1]
            top.pending = item
            self.push(right_power, self.builder.depth(top.left))
        elif isinstance(item, _Operator):                    # a prefix operator
            top.pending = item
            self.push(_PREFIX[item.symbol], 0)
        else:                                                # an operand
            self.fits(self.builder.depth(item) + len(self.frames) - 1)
            top.left = item

    def finish(self) -> Any:
        while len(self.frames) > 1:
            self.reduce(None)
        return self.frames[0].left

    def push(self, min_power: int, left_depth: int) -> None:
        """A level for the operand of the top level's operator, whose left operand (if any) is
        `left_depth` deep. Each level below will be one more level around that operand."""
        self.frames.append(_Frame(min_power))
        self.fits(max(left_depth, 1) + len(self.frames) - 1)

    def fits(self, levels: int) -> None:
        """The chain is sure to nest at least `levels` deep: stop the parse if that is too deep."""
        if levels > MAX_DEPTH:
            assert self.start is not None
            raise _TooDeepExpression(self.start)

    def reduce(self, following: _Operator | None) -> None:
        """The top level is complete: its value becomes the right operand of the level below."""
        right = self.frames.pop().left
        frame = self.frames[-1]
        op, left = frame.pending, frame.left
        assert op is not None
        builder = self.builder
        node: Any
        if left is None:
            node = ast.Unary(op.symbol, right, op.span.to(builder.outer_span(right)))
        else:
            span = builder.outer_span(left).to(builder.outer_span(right))
            if op.symbol in _COMPARISONS:
                node = ast.Compare(op.symbol, left, right, span)
                if following is not None and following.symbol in _COMPARISONS:
                    builder.diagnostics.append(error(
                        "E0101", "comparisons do not chain", following.span,
                        label="a second comparison", help="write `a < b and b < c`"))
            elif op.symbol in ("and", "or"):
                node = ast.Logic(op.symbol, left, right, span)
            else:
                node = ast.Binary(op.symbol, left, right, span)
        children = (right,) if left is None else (left, right)
        frame.left = builder.nested(node, children, within=len(self.frames) - 1,
                                    start=self.start)
        frame.pending = None


class _Default:
    def __init__(self, default: Any) -> None:
        self.default = default


class _Weight:
    def __init__(self, weight: Any) -> None:
        self.weight = weight


class _RoleMap:
    def __init__(self, bindings: list[ast.RoleBinding]) -> None:
        self.bindings = bindings


class _PhaseArgs:
    def __init__(self, args: list[ast.Argument]) -> None:
        self.args = args


class _Retry:
    def __init__(self, count: ast.Expr) -> None:
        self.count = count


# ------------------------------------------------------------------------------------- parsing

def parse_module(text: str, path: str) -> tuple[ast.Module | None, list[Diagnostic]]:
    """Parse a whole `.rapid` file. Returns the module (None on a syntax error) and diagnostics.

    A leading BOM is dropped and CR, CRLF and LF all end a line (`syntax.source_text`); positions
    are those of that text."""
    module, diagnostics = _parse_module_cached(ast.source_text(text), path)
    return module, list(diagnostics)


@lru_cache(maxsize=64)
def _parse_module_cached(text: str, path: str) -> tuple[ast.Module | None, tuple[Diagnostic, ...]]:
    """The AST is immutable, so a file seen again (a stdlib primitive `use`d by every program a
    process checks) is parsed once."""
    module, diagnostics = _parse_file(text, path)
    return module, tuple(diagnostics)


def forget_parsed() -> None:
    """Drop the parse cache (benchmarks measure cold parses)."""
    _parse_module_cached.cache_clear()


def _parse_file(text: str, path: str) -> tuple[ast.Module | None, list[Diagnostic]]:
    module, diagnostics = _parse(text, path, "start")
    if module is not None or len(diagnostics) != 1 or diagnostics[0].code not in _SYNTAX_CODES:
        return module, diagnostics
    # Report the first syntax error of every top-level declaration, not only of the file.
    found: list[Diagnostic] = []
    for offset, lines, chunk in _declaration_chunks(text):
        _, chunk_diagnostics = _parse(chunk, path, "start")
        found.extend(_moved(d, offset, lines) for d in chunk_diagnostics)
    return None, found or diagnostics


def parse_expression(text: str, path: str, *, line: int = 1,
                     col: int = 1) -> tuple[Any, list[Diagnostic]]:
    """Parse one expression that starts at (line, col) of `path` (the YAML form uses this)."""
    return _parse(_pad(text, line, col), path, "expr_only")


def parse_type(text: str, path: str, *, line: int = 1,
               col: int = 1) -> tuple[Any, list[Diagnostic]]:
    """Parse one type that starts at (line, col) of `path`."""
    return _parse(_pad(text, line, col), path, "type_only")


def _pad(text: str, line: int, col: int) -> str:
    """Shift `text` so lark's lines and columns equal those in the enclosing file.

    The leading newlines are dropped by the postlexer, so they change positions and nothing else.
    """
    return "\n" * (line - 1) + " " * (col - 1) + text


_SYNTAX_CODES = {"E0101", "E0102", "E0103", "E0104", "E0107", "E0409"}


def _parse(text: str, path: str, start: str) -> tuple[Any, list[Diagnostic]]:
    builder = _Builder(path)
    try:
        node = _runtime().parse(text, start, builder, _Newlines())
    except _TooDeep as deep:
        span = _token_span(path, deep.token)
        return None, [error("E0107", f"brackets nest deeper than {MAX_NESTING} levels", span,
                            help="split the expression with `let` or resolve entries")]
    except _TooDeepExpression as deep:
        at = deep.span
        return None, [error("E0409", f"an expression nests deeper than {MAX_DEPTH} levels",
                            Span(path, at.start, at.start, at.line, at.col, at.line, at.col + 1),
                            help="split it with `def`s, `let`s or resolve entries")]
    except UnexpectedInput as exc:
        return None, [_syntax_error(exc, text, path)]
    return node, builder.diagnostics


def _token_span(path: str, tok: Token) -> Span:
    return Span(path, tok.start_pos or 0, tok.end_pos or 0, tok.line or 1, tok.column or 1,
                tok.end_line or tok.line or 1, tok.end_column or (tok.column or 1) + 1)


_TOP_LEVEL = re.compile(r"^(use|relation|def|primitive|strategy)\b", re.MULTILINE)


def _declaration_chunks(text: str) -> list[tuple[int, int, str]]:
    """(offset, lines before it, text) of each top-level declaration. Each chunk is parsed on
    its own, so a file of n declarations with a syntax error costs O(n) to re-parse, not
    O(n^2); `_moved` puts the positions of its diagnostics back into the file."""
    starts = [m.start() for m in _TOP_LEVEL.finditer(text)]
    if len(starts) < 2:
        return []
    if starts[0] > 0:
        starts.insert(0, 0)
    chunks = []
    lines = 0
    for a, b in zip(starts, [*starts[1:], len(text)], strict=True):
        chunks.append((a, lines, text[a:b]))
        lines += text.count("\n", a, b)
    return chunks


def _moved(d: Diagnostic, offset: int, lines: int) -> Diagnostic:
    """A diagnostic of a chunk that starts a line, at its place in the whole file."""
    def move(s: Span) -> Span:
        return Span(s.path, s.start + offset, s.end + offset, s.line + lines, s.col,
                    s.end_line + lines, s.end_col)
    return replace(d, span=move(d.span), related=tuple((t, move(s)) for t, s in d.related))


# -------------------------------------------------------------------------- syntax error text

_WORDS = {
    "NAME": "a name", "TYPE_NAME": "a type such as `Length`", "NUMBER": "a number",
    "STRING": "a string in double quotes", "_NL": "a new line", "$END": "the end of the file",
    "SIGNED_INT": "an integer exponent",
}
_EXPRESSION_START = {"NAME", "NUMBER", "LPAR", "LSQB", "MINUS", "NOT", "IF"}
_OPERATOR_TEXT = {"or", "and", "<", "<=", ">", ">=", "==", "!=", "+", "-", "*", "/", "^"}
_GROUPS = (
    ({"USE", "RELATION", "DEF", "PRIMITIVE", "STRATEGY"},
     "a declaration (`use`, `relation`, `def`, `primitive` or `strategy`)"),
    ({"GOAL", "ROLES", "REQUIRES", "PARAMS", "RESOLVE", "SUCCESS", "COST", "MOTION", "OPTIMIZE",
      "FILTER"}, "a primitive block (`goal`, `roles`, `requires`, `params`, `resolve`, `success`, "
                 "`cost`, `motion`, `optimize` or `filter`)"),
    ({"GOAL", "ROLES", "REQUIRES", "LET", "PHASE", "SUCCESS", "FILTER"},
     "a strategy block (`goal`, `roles`, `requires`, `let`, `phase`, `success` or `filter`)"),
)


def _describe_expected(expected: set[str]) -> str:
    texts = _terminal_text()
    expected = set(expected)
    words: list[str] = []
    operators = {name for name, text in texts.items() if text in _OPERATOR_TEXT}
    if operators <= expected:
        words.append("an operator")
        expected -= operators
    for group, word in _GROUPS:
        if group <= expected:
            words.append(word)
            expected -= group | {"$END", "_NL"}
    if _EXPRESSION_START <= expected | {"NOT", "IF"} and {"NAME", "NUMBER"} <= expected:
        words.append("an expression")
        expected -= _EXPRESSION_START
    for name in sorted(expected, key=lambda n: (n not in _WORDS, texts.get(n, n))):
        if name in _WORDS:
            words.append(_WORDS[name])
        elif name in texts:
            words.append(f"`{texts[name]}`")
        else:
            words.append(name.lower())
    words = list(dict.fromkeys(words))
    if len(words) > 8:
        words = [*words[:7], "..."]
    if len(words) == 1:
        return words[0]
    return ", ".join(words[:-1]) + " or " + words[-1]


def _found(tok: Token) -> str:
    if tok.type == "$END":
        return "the end of the file"
    if tok.type == "_NL":
        return "`;`" if tok.value == ";" else "the end of the line"
    return f"`{tok}`"


def _syntax_error(exc: UnexpectedInput, text: str, path: str) -> Diagnostic:
    if isinstance(exc, UnexpectedCharacters):
        pos = exc.pos_in_stream
        char = text[pos] if pos < len(text) else ""
        span = Span(path, pos, pos + 1, exc.line, exc.column, exc.line, exc.column + 1)
        if char == '"':
            return error("E0104", "unterminated string", span, label="this string never ends",
                         help='close it with `"` on the same line')
        shown = repr(char)[1:-1] if not char.isprintable() else char
        help_text = None
        if char == "'":
            help_text = 'strings use double quotes: "..."'
        elif char == "@" or char == "$":
            help_text = "names are letters, digits and `_`"
        return error("E0102", f"unexpected character `{shown}`", span, help=help_text)
    if isinstance(exc, UnexpectedToken):
        tok = exc.token
        # `accepts` comes from the parser state; `expected` also lists always-lexed newlines.
        expected = set(exc.accepts or exc.expected)
        wanted = _describe_expected(expected)
        if tok.type == "$END":
            line = text.count("\n") + 1
            col = len(text) - (text.rfind("\n") + 1) + 1
            span = Span(path, len(text), len(text), line, col, line, col)
            help_text = "a `{` is not closed" if "RBRACE" in expected else None
            return error("E0103", f"unexpected end of file; expected {wanted}", span,
                         help=help_text)
        span = _token_span(path, tok)
        help_text = _syntax_help(tok, expected)
        return error("E0101", f"expected {wanted}, found {_found(tok)}", span,
                     label="unexpected here", help=help_text)
    span = Span.point(path, getattr(exc, "line", 1), getattr(exc, "column", 1))
    return error("E0101", "syntax error", span)


def _syntax_help(tok: Token, expected: set[str]) -> str | None:
    texts = _terminal_text()
    value = str(tok)
    if tok.type == "TYPE_NAME" and "NAME" in expected:
        return "names of roles, params and values start with a lower-case letter"
    if tok.type == "NAME" and "TYPE_NAME" in expected:
        return "types are capitalized, e.g. `Object`, `Length`, `Vec[Length]`"
    if tok.type == "_NL" and "RBRACE" in expected:
        return "close the block with `}`"
    if value == "=" and "COLON" in expected:
        return "declare with `name: Type`"
    if texts.get(tok.type) in {"=", "=="} and "EQUAL" not in expected:
        return "use `==` to compare and `=` only to name a value"
    return None
