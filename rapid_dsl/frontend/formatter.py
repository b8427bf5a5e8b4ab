"""Canonical `.rapid` text: `rapidc fmt`.

`format_module(module)` prints an AST in the canonical layout: 2-space indent, every block on its
own line, one statement per line, single spaces around binary operators (none around `^`), and the
fewest parentheses that keep the tree. Numbers are printed as written (`Number.text`).
`parse(format_module(m)) == m` for every module the parser or the YAML form produces.

The AST has no comments, so `format_source(text, path)` puts them back line by line: a comment on
its own line stays before the statement that follows it, a comment after code stays after the
statement that ends on its line. Blank lines between statements are kept (runs become one).
Before returning, `format_source` parses its output again and insists on the same AST and the same
comments in the same order; a mismatch is a bug and raises `FormatError` rather than losing text.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.language.diagnostics import Diagnostic, Span

INDENT = 2
WIDTH = 100  # a block stays on one line up to this width (long expressions are never broken)

# Binding strength, loosest first; mirrors the precedence levels of grammar/rapid.lark.
_IF, _OR, _AND, _NOT, _CMP, _SUM, _PRODUCT, _UNARY, _POWER, _POSTFIX, _ATOM = range(11)
_BINARY_LEVEL = {"+": _SUM, "-": _SUM, "*": _PRODUCT, "/": _PRODUCT}


class FormatError(RuntimeError):
    """The formatted text would not mean the same program; nothing is written."""


# ------------------------------------------------------------------------------- expressions

def format_expr(e: ast.Expr) -> str:
    """One expression on one line, with minimal parentheses."""
    return _expr(e, _IF)


def _level(e: ast.Expr) -> int:
    match e:
        case ast.IfExpr():
            return _IF
        case ast.Logic(op="or"):
            return _OR
        case ast.Logic():
            return _AND
        case ast.Unary(op="not"):
            return _NOT
        case ast.Compare():
            return _CMP
        case ast.Binary(op="^"):
            return _POWER
        case ast.Binary(op=op):
            return _BINARY_LEVEL[op]
        case ast.Unary():
            return _UNARY
        case ast.Call() | ast.Component():
            return _POSTFIX
        case _:
            return _ATOM


def _expr(e: ast.Expr, need: int) -> str:
    """`e` printed where the grammar needs a level of at least `need`."""
    text = _bare(e)
    return f"({text})" if _level(e) < need else text


def _bare(e: ast.Expr) -> str:
    match e:
        case ast.Name(name=name):
            return name
        case ast.Number(text=text):
            return text
        case ast.Vector(items=items):
            return "[" + ", ".join(_expr(i, _IF) for i in items) + "]"
        case ast.Unary(op="not", operand=operand):
            return "not " + _expr(operand, _NOT)
        case ast.Unary(operand=operand):
            return "-" + _expr(operand, _UNARY)
        case ast.Binary(op="^", left=left, right=right):
            return _expr(left, _POSTFIX) + "^" + _expr(right, _UNARY)
        case ast.Binary(op=op, left=left, right=right):
            level = _BINARY_LEVEL[op]
            # Left-associative: the right operand must bind tighter than the operator.
            right_need = _UNARY if level == _PRODUCT else _PRODUCT
            return f"{_expr(left, level)} {op} {_expr(right, right_need)}"
        case ast.Compare(op=op, left=left, right=right):
            return f"{_expr(left, _SUM)} {op} {_expr(right, _SUM)}"
        case ast.Logic(op="or", left=left, right=right):
            return f"{_expr(left, _OR)} or {_expr(right, _AND)}"
        case ast.Logic(left=left, right=right):
            return f"{_expr(left, _AND)} and {_expr(right, _NOT)}"
        case ast.IfExpr(cond=cond, then=then, orelse=orelse):
            return f"if {_expr(cond, _IF)} then {_expr(then, _IF)} else {_expr(orelse, _IF)}"
        case ast.Call(func=func, args=args):
            return func.name + "(" + ", ".join(_arg(a) for a in args) + ")"
        case ast.Component(target=target, field=name):
            # `3.x` would lex as the number `3.` with unit `x`: numbers always get parentheses.
            need = _ATOM + 1 if isinstance(target, ast.Number) else _POSTFIX
            return _expr(target, need) + "." + name.name
    raise TypeError(f"not an expression: {e!r}")


def _arg(a: ast.Arg) -> str:
    value = _expr(a.value, _IF)
    return f"{a.name.name}={value}" if a.name is not None else value


# ------------------------------------------------------------------------------------- types

def format_type(t: ast.TypeExpr) -> str:
    match t:
        case ast.TypeName(name=name):
            return name
        case ast.TypeApply(name=name, arg=arg):
            return f"{name}[{format_type(arg)}]"
        case ast.TypeBinary(op=op, left=left, right=right):
            right_text = format_type(right)
            if isinstance(right, ast.TypeBinary):
                right_text = f"({right_text})"
            return f"{format_type(left)} {op} {right_text}"
        case ast.TypePower(base=base, exponent=exponent):
            base_text = format_type(base)
            if isinstance(base, (ast.TypeBinary, ast.TypePower)):
                base_text = f"({base_text})"
            return f"{base_text}^{exponent}"
    raise TypeError(f"not a type: {t!r}")


def format_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


# --------------------------------------------------------------------------------- statements

@dataclass(slots=True)
class _Line:
    indent: int
    text: str
    start: int              # source lines this output line came from (0: no source)
    end: int
    opens: bool = False     # ends with `{`
    closes: bool = False    # is a lone `}`
    before: list[str | None] = field(default_factory=list)  # comments (None: a blank line)
    trailing: str | None = None


class _Layout:
    """AST -> output lines, each remembering the source lines it stands for."""

    def __init__(self, comment_lines: frozenset[int]) -> None:
        self.comment_lines = comment_lines
        self.lines: list[_Line] = []

    def emit(self, indent: int, text: str, span: Span, *, end: int | None = None,
             opens: bool = False) -> None:
        self.lines.append(_Line(indent, text, span.line, span.end_line if end is None else end,
                                opens=opens))

    def close(self, indent: int, span: Span) -> None:
        self.lines.append(_Line(indent, "}", span.end_line, span.end_line, closes=True))

    def inner_comments(self, span: Span) -> bool:
        return any(span.line <= c < span.end_line for c in self.comment_lines)

    def fits(self, indent: int, text: str, span: Span) -> bool:
        return indent + len(text) <= WIDTH and not self.inner_comments(span)

    def block(self, indent: int, head: str, span: Span, body: Iterable[tuple[str, Span]]) -> None:
        """A block of statements: `head { s }` on one line if it has one short statement."""
        items = list(body)
        if not items:
            self.emit(indent, head + " {}", span)
            return
        if len(items) == 1 and self.fits(indent, f"{head} {{ {items[0][0]} }}", span):
            self.emit(indent, f"{head} {{ {items[0][0]} }}", span)
            return
        self.emit(indent, head + " {", span, end=span.line, opens=True)
        for text, item_span in items:
            self.emit(indent + INDENT, text, item_span)
        self.close(indent, span)

    def listing(self, indent: int, head: str, span: Span, entries: list[tuple[str, Span]]) -> None:
        """`roles`/`params`: one line when short and free of comments, else one entry per line."""
        joined = ", ".join(text for text, _ in entries)
        one_line = f"{head} {{ {joined} }}" if entries else head + " {}"
        if self.fits(indent, one_line, span):
            self.emit(indent, one_line, span)
        else:
            self.block(indent, head, span, entries)

    # declarations -------------------------------------------------------------------------
    def decl(self, d: ast.Decl) -> None:
        match d:
            case ast.Use():
                self.emit(0, _use(d), d.span)
            case ast.RelationDecl(name=name, params=params, body=body):
                self.emit(0, f"relation {name.name}({_typed(params)}) = {format_expr(body)}",
                          d.span)
            case ast.DefDecl(name=name, params=params, returns=returns, body=body):
                self.emit(0, f"def {name.name}({_typed(params)}) -> {format_type(returns)} = "
                             f"{format_expr(body)}", d.span)
            case ast.Primitive(name=name, blocks=blocks) | ast.Strategy(name=name, blocks=blocks):
                keyword = "primitive" if isinstance(d, ast.Primitive) else "strategy"
                self.emit(0, f"{keyword} {name.name} {{", d.span, end=d.span.line, opens=True)
                for b in blocks:
                    self.statement(INDENT, b)
                self.close(0, d.span)
            case _:
                raise TypeError(f"not a declaration: {d!r}")

    def statement(self, indent: int, b: ast.PrimitiveBlock | ast.StrategyBlock) -> None:
        match b:
            case ast.Goal(text=text):
                self.emit(indent, "goal " + format_string(text), b.span)
            case ast.Roles(roles=roles):
                self.listing(indent, "roles", b.span,
                             [(f"{r.name.name}: {format_type(r.type)}", r.span) for r in roles])
            case ast.Params(params=params):
                self.listing(indent, "params", b.span, [(_param(p), p.span) for p in params])
            case ast.Requires(relations=exprs):
                self.block(indent, "requires", b.span, [(format_expr(e), e.span) for e in exprs])
            case ast.Success(clauses=exprs):
                self.block(indent, "success", b.span, [(format_expr(e), e.span) for e in exprs])
            case ast.Filter(clauses=exprs):
                self.block(indent, "filter", b.span, [(format_expr(e), e.span) for e in exprs])
            case ast.Resolve(features=features):
                self.block(indent, "resolve", b.span,
                           [(f"{a.name.name} = {format_expr(a.value)}", a.span) for a in features])
            case ast.CostFinal(expr=expr):
                self.emit(indent, "cost final = " + format_expr(expr), b.span)
            case ast.CostProgress(weight=weight, expr=expr):
                weight_text = f" weight {format_expr(weight)}" if weight is not None else ""
                self.emit(indent, f"cost progress{weight_text} = {format_expr(expr)}", b.span)
            case ast.Motion(items=items):
                self.block(indent, "motion", b.span, [(_motion_item(i), i.span) for i in items])
            case ast.Optimize(settings=settings):
                self.block(indent, "optimize", b.span,
                           [(f"{s.name.name} {format_expr(s.value)}", s.span) for s in settings])
            case ast.Let(name=name, value=value):
                self.emit(indent, f"let {name.name} = {format_expr(value)}", b.span)
            case ast.Phase():
                self.phase(indent, b)
            case _:
                raise TypeError(f"not a block: {b!r}")

    def phase(self, indent: int, p: ast.Phase) -> None:
        roles = ", ".join(f"{r.role.name}={r.target.name}" for r in p.role_map)
        head = f"phase {p.name.name}: {p.primitive.name}({roles})"
        head_end = max([p.primitive.span.end_line, *(r.span.end_line for r in p.role_map)])
        args = [f"{a.name.name} = {_argument_value(a.value)}" for a in p.args]
        tail = f" retry {format_expr(p.retry)}" if p.retry is not None else ""
        tail += f" on_fail {p.on_fail.name}" if p.on_fail is not None else ""
        if not args:
            self.emit(indent, head + tail, p.span)
        elif len(args) == 1 and self.fits(indent, f"{head} {{ {args[0]} }}{tail}", p.span):
            self.emit(indent, f"{head} {{ {args[0]} }}{tail}", p.span)
        else:
            self.emit(indent, head + " {", p.span, end=max(head_end, p.span.line), opens=True)
            for text, a in zip(args, p.args, strict=True):
                self.emit(indent + INDENT, text, a.span)
            self.close(indent, p.span)
            self.lines[-1].text += tail


def _use(u: ast.Use) -> str:
    if u.file is not None:
        return "use " + format_string(u.file)
    path = ".".join(u.module or ())
    if len(u.names) == 1:
        return f"use {path}.{u.names[0].name}" if path else f"use {u.names[0].name}"
    return f"use {path}.{{{', '.join(n.name for n in u.names)}}}"


def _typed(params: tuple[ast.TypedName, ...]) -> str:
    return ", ".join(f"{p.name.name}: {format_type(p.type)}" for p in params)


def _param(p: ast.ParamDecl) -> str:
    text = f"{p.name.name}: {format_type(p.type)}"
    if p.low is not None and p.high is not None:
        text += f" in [{format_expr(p.low)}, {format_expr(p.high)}]"
    if p.default is not None:
        text += f" = {format_expr(p.default)}"
    return text


def _motion_item(item: ast.Keypoint | ast.MotionSetting) -> str:
    if isinstance(item, ast.MotionSetting):
        return f"{item.key} {format_expr(item.value)}"
    text = f"keypoint {item.name.name} = {format_expr(item.point)}"
    if item.yaw is not None:
        text += f" yaw {format_expr(item.yaw)}"
    if item.pitch is not None:
        text += f" pitch {format_expr(item.pitch)}"
    if item.roll is not None:
        text += f" roll {format_expr(item.roll)}"
    if item.gripper is not None:
        text += f" gripper {item.gripper}"
    return text


def _argument_value(value: ast.Expr | ast.Solve) -> str:
    if not isinstance(value, ast.Solve):
        return format_expr(value)
    subject = "; ".join(format_expr(c) for c in value.constraints)
    return (f"solve {value.var.name}: {format_type(value.type)} minimize "
            f"{format_expr(value.objective)} subject {{{f' {subject} ' if subject else ''}}}")


# --------------------------------------------------------------------------------- whole files

def format_module(module: ast.Module) -> str:
    """The canonical text of a module (no comments: the AST has none)."""
    return _render(module, _Source.empty())


def format_source(text: str, path: str) -> tuple[str | None, list[Diagnostic]]:
    """Canonical text of a `.rapid` source, keeping its comments and blank lines.

    Returns (None, diagnostics) when the source has syntax errors. Raises FormatError if the result
    would not parse to the same AST with the same comments (a formatter bug; nothing is lost).
    """
    from rapid_dsl.frontend.parser import parse_module

    text = ast.source_text(text)   # CR and CRLF end lines here as in the parser; output is LF
    module, diagnostics = parse_module(text, path)
    if module is None:
        return None, diagnostics
    source = _Source.scan(text)
    result = _render(module, source)
    again, _ = parse_module(result, path)
    if again != module:
        raise FormatError(f"formatting {path} would change its program")
    if [c.text for c in _Source.scan(result).comments] != [c.text for c in source.comments]:
        raise FormatError(f"formatting {path} would move or lose comments")
    return result, diagnostics


@dataclass(frozen=True, slots=True)
class _Comment:
    line: int
    text: str
    trailing: bool          # code before it on the same line


@dataclass(frozen=True, slots=True)
class _Source:
    comments: tuple[_Comment, ...]
    blank: frozenset[int]

    @staticmethod
    def empty() -> _Source:
        return _Source((), frozenset())

    @staticmethod
    def scan(text: str) -> _Source:
        comments: list[_Comment] = []
        blank: set[int] = set()
        lines = text.split("\n")   # after source_text, the only line break
        for number, line in enumerate(lines, 1):
            if not line.strip():
                blank.add(number)
                continue
            at = _comment_start(line)
            if at is not None:
                comments.append(_Comment(number, line[at:].rstrip(), bool(line[:at].strip())))
        return _Source(tuple(comments), frozenset(blank))


def _comment_start(line: str) -> int | None:
    """Index of the `#` that starts a comment, skipping `#` inside strings."""
    in_string = escaped = False
    for i, char in enumerate(line):
        if in_string:
            if escaped:
                escaped = False
            elif char == "\\":
                escaped = True
            elif char == '"':
                in_string = False
        elif char == '"':
            in_string = True
        elif char == "#":
            return i
    return None


def _render(module: ast.Module, source: _Source) -> str:
    layout = _Layout(frozenset(c.line for c in source.comments))
    first_lines: list[int] = []     # index of each declaration's first output line
    for d in module.decls:
        first_lines.append(len(layout.lines))
        layout.decl(d)
    lines = layout.lines
    tail = _attach(lines, source)
    # Top level: a blank line around every primitive and strategy, and after the `use` lines.
    for k in range(1, len(module.decls)):
        before, after = module.decls[k - 1], module.decls[k]
        blocky = (ast.Primitive, ast.Strategy)
        if (isinstance(before, blocky) or isinstance(after, blocky)
                or (isinstance(before, ast.Use) and not isinstance(after, ast.Use))):
            line = lines[first_lines[k]]
            if not line.before or line.before[0] is not None:
                line.before.insert(0, None)
    out: list[str] = []
    previous: _Line | None = None
    for line in lines:
        _emit_before(out, line.before, line.indent + (INDENT if line.closes else 0),
                     after_open=previous is None or previous.opens, before_close=line.closes)
        text = " " * line.indent + line.text
        out.append(f"{text}  {line.trailing}" if line.trailing else text)
        previous = line
    _emit_before(out, tail, 0, after_open=previous is None, before_close=True)
    return "\n".join(out) + "\n" if out else ""


def _attach(lines: list[_Line], source: _Source) -> list[str | None]:
    """Hang comments and blank lines on the output lines; returns what follows the last line."""
    items: list[tuple[int, str | None, bool]] = [(c.line, c.text, c.trailing)
                                                 for c in source.comments]
    items += [(b, None, False) for b in source.blank]
    items.sort(key=lambda item: item[0])
    tail: list[str | None] = []
    i = 0
    previous_end = 0
    for number, text, trailing in items:
        while i < len(lines) and lines[i].end < number:
            previous_end = lines[i].end
            i += 1
        if i == len(lines):
            tail.append(text)
            continue
        line = lines[i]
        if text is None:
            # A blank line counts only between statements, not inside one.
            if previous_end < number < line.start:
                line.before.append(None)
        elif trailing and number == line.end:
            # Several output lines may come from this source line: the last one gets it.
            j = i
            while j + 1 < len(lines) and lines[j + 1].end == number:
                j += 1
            lines[j].trailing = text
        else:
            line.before.append(text)
    return tail


def _emit_before(out: list[str], items: list[str | None], indent: int, *, after_open: bool,
                 before_close: bool) -> None:
    kept: list[str | None] = []
    for item in items:
        if item is None and (not kept and after_open or kept and kept[-1] is None):
            continue
        kept.append(item)
    while before_close and kept and kept[-1] is None:
        kept.pop()
    out.extend("" if item is None else " " * indent + item for item in kept)
