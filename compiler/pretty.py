"""Python literal text for the plan: calls and tuples laid out on one line when they fit.

Used by `lower` to render the objects a generated module builds (`RT.Primitive(...)` and the like),
so that layout is decided in Python and the template only interpolates lines. `literal` is the one
way text from a program (or its file name) enters generated code.
"""

from __future__ import annotations

from dataclasses import dataclass

WIDTH = 100          # the project's line length
INDENT = "    "


@dataclass(frozen=True, slots=True)
class Raw:
    """Python text used as it is; `note` (generated text only) goes in a comment at line end."""

    text: str
    note: str = ""


@dataclass(frozen=True, slots=True)
class Call:
    function: str
    args: tuple[Node | str, ...] = ()
    kwargs: tuple[tuple[str, Node | str], ...] = ()


@dataclass(frozen=True, slots=True)
class Tuple:
    items: tuple[Node | str, ...]


Node = Raw | Call | Tuple


def literal(value: str) -> str:
    """A Python string literal in double quotes, all ASCII and on one line, whatever `value` holds.

    Printable ASCII stays as it is, with `"` and `\\` escaped; everything else (line breaks,
    control characters, NUL, lone surrogates, any non-ASCII character) becomes an escape, so the
    literal cannot end early, span lines, fail to encode or look like something else.

    >>> print(literal('say "hi"\\n\\u00e9'))
    "say \\"hi\\"\\n\\xe9"
    """
    return '"' + "".join(_ESCAPED.get(c) or (c if " " <= c <= "~" else _escape(c))
                         for c in value) + '"'


_ESCAPED = {'"': '\\"', "\\": "\\\\", "\n": "\\n", "\r": "\\r", "\t": "\\t"}


def _escape(c: str) -> str:
    code = ord(c)
    if code < 0x100:
        return f"\\x{code:02x}"
    return f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"


def nesting(text: str) -> int:
    """How deep brackets nest in Python text (string literals skipped)."""
    depth = deepest = 0
    quoted = escaped = False
    for c in text:
        if quoted:
            escaped, quoted = (False, True) if escaped else (c == "\\", c != '"')
        elif c == '"':
            quoted = True
        elif c in "([{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in ")]}":
            depth -= 1
    return deepest


def render_assignment(name: str, value: Node) -> tuple[str, ...]:
    """`name = value` as lines; the notes of the constants on a line go in a comment at its end."""
    lines = _render(value, indent=0, column=len(name) + 3)
    lines[0] = (f"{name} = {lines[0][0]}", lines[0][1])
    return tuple(text + comment(notes) for text, notes in lines)


def comment(notes: tuple[str, ...] | list[str]) -> str:
    """The end-of-line comment holding generated notes (`  # 15deg, 2cm`), or ""."""
    return f"  # {', '.join(notes)}" if notes else ""


def _flat(node: Node | str) -> str:
    match node:
        case str():
            return node
        case Raw(text=text):
            return text
        case Call(function=function, args=args, kwargs=kwargs):
            parts = [_flat(a) for a in args] + [f"{k}={_flat(v)}" for k, v in kwargs]
            return f"{function}({', '.join(parts)})"
        case Tuple(items=items):
            if len(items) == 1:
                return f"({_flat(items[0])},)"
            return f"({', '.join(_flat(i) for i in items)})"


def _notes(node: Node | str) -> tuple[str, ...]:
    match node:
        case Raw(note=note):
            return (note,) if note else ()
        case Call(args=args, kwargs=kwargs):
            return tuple(n for part in (*args, *(v for _, v in kwargs)) for n in _notes(part))
        case Tuple(items=items):
            return tuple(n for item in items for n in _notes(item))
    return ()


Line = tuple[str, tuple[str, ...]]   # text, notes


def _render(node: Node | str, *, indent: int, column: int) -> list[Line]:
    """Lines of `node`, whose first character is at `column` and whose continuation lines start
    at `indent` (both absolute); the first line is returned without leading spaces."""
    flat = _flat(node)
    if column + len(flat) <= WIDTH or isinstance(node, str | Raw):
        return [(flat, _notes(node))]
    if isinstance(node, Call):
        parts: list[tuple[str, Node | str]] = [("", a) for a in node.args]
        parts += [(f"{k}=", v) for k, v in node.kwargs]
        opener = f"{node.function}("
    else:
        parts = [("", i) for i in node.items]
        opener = "("
    inner_indent = indent + len(INDENT)
    lines: list[Line] = [(opener, ())]
    for prefix, part in parts:
        inner = _render(part, indent=inner_indent, column=inner_indent + len(prefix))
        lines.append((f"{' ' * inner_indent}{prefix}{inner[0][0]}", inner[0][1]))
        lines += inner[1:]
        lines[-1] = (lines[-1][0] + ",", lines[-1][1])
    lines.append((" " * indent + ")", ()))
    return lines
