"""The YAML form of a program (LANGUAGE.md section 7): the same AST from structured text.

A YAML program is a list with one mapping per declaration, the block names as keys and expressions
as strings in `.rapid` syntax:

```yaml
- use: stdlib.{push, flip}
- primitive: nudge
  goal: "Nudge the object"
  roles: {target: Object, hand: Manipulator}
  params:
    gap: {type: Length, range: [1cm, 5cm], default: 2cm}
  success: ["distance(hand, target) < gap"]
  cost: {final: "distance(hand, target) / 1cm"}
  motion:
    keypoints:
      - {name: reach, at: "pos(target) + 3cm * up", gripper: open}
    duration: 2s
```

`parse_yaml_module(text, path)` returns `(module | None, diagnostics)` like `parser.parse_module`.
YAML is read node by node (ruamel.yaml's composer), so every value keeps its line and column; every
scalar is kept as the text written (`0.10` stays `0.10`), and expressions are parsed by
`parser.parse_expression` at their place in the file, so diagnostics point at YAML lines. The shape
(keys and kinds of values) is checked by pydantic models that also give the JSON Schema
(`json_schema()`, printed by `rapidc schema`). Nothing in a YAML file makes this module raise.

Positions inside an expression are exact for plain and quoted one-line scalars; in block scalars
(`|`, `>`) and scalars folded over several lines, only the first line's positions are exact.
"""

from __future__ import annotations

import difflib
import re
import types
import typing
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Annotated, Any, Literal, Union

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    TypeAdapter,
    ValidationError,
    WithJsonSchema,
)

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.parser import parse_expression, parse_type
from rapid_dsl.language.diagnostics import Diagnostic, Span, error
from rapid_dsl.language.safe_yaml import TooManyTokens, counting_scanner

# Diagnostic codes of the YAML form (the E011x range).
E_YAML_SYNTAX = "E0110"
E_YAML_SHAPE = "E0111"
E_YAML_DECLARATION = "E0112"
E_YAML_DUPLICATE_KEY = "E0113"
E_YAML_NAME = "E0114"
E_YAML_TEXT = "E0115"
E_YAML_LIMIT = "E0116"

CODES: dict[str, str] = {
    E_YAML_SYNTAX: "the file is not well-formed YAML",
    E_YAML_SHAPE: "a key or value does not fit the YAML form of a program",
    E_YAML_DECLARATION: "a list item is not one declaration (use, relation, def, primitive, "
                        "strategy)",
    E_YAML_DUPLICATE_KEY: "a key appears twice in one YAML mapping",
    E_YAML_NAME: "a name in the YAML form is not a valid name",
    E_YAML_TEXT: "a text holds a line break or a lone surrogate, which `.rapid` text cannot hold",
    E_YAML_LIMIT: "the YAML nests too deeply, is too large, or has aliases that refer to "
                  "themselves",
}

SCHEMA_ID = "urn:rapid-dsl:program-yaml:0"
MAX_DEPTH = 50          # a real program nests about 6 levels
MAX_NODES = 50_000      # stops alias bombs (`&a [*b, *b, ...]` nested)
_SURROGATE = re.compile("[\ud800-\udfff]")
_SURROGATE_PAIR = re.compile("[\ud800-\udbff][\udc00-\udfff]")
MAX_TOKENS = 4 * MAX_NODES   # read before nodes are counted: ~25 us each, so at most ~5 s

KINDS = ("use", "relation", "def", "primitive", "strategy")


# ----------------------------------------------------------------------------------- models

class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


# Every scalar is loaded as text; the schema also allows numbers so editors accept `weight: 0.1`.
Expr = Annotated[str, WithJsonSchema({
    "type": ["string", "number"],
    "description": "An expression in .rapid syntax, e.g. `distance(hand, target) - 1cm`."})]
TypeText = Annotated[str, Field(description="A type, e.g. `Object`, `Length`, `Vec[Length]`, "
                                            "`Length / Time`.")]
Name = Annotated[str, Field(pattern=r"^[a-z_][A-Za-z0-9_]*$",
                            description="A name: a lower-case letter or `_`, then letters, digits "
                                        "or `_`.")]
ExprList = Annotated[list[Expr], Field(description="Expressions, one per item; all must hold.")]


class ParamSpec(_Model):
    """A primitive parameter: `angle: {type: Angle, range: [20deg, 120deg], default: 90deg}`."""

    type: TypeText
    range: Annotated[list[Expr], Field(min_length=2, max_length=2,
                                       description="[low, high], both included")] | None = None
    default: Expr | None = None


class Cost(_Model):
    """`cost final = ...` and `cost progress weight W = ...`."""

    final: Expr | None = None
    progress: Expr | None = None
    weight: Expr | None = Field(None, description="Weight of `progress` (default 1).")


class KeypointSpec(_Model):
    name: Name
    at: Expr = Field(description="The hand position (a Point) at the primitive's start.")
    yaw: Expr | None = None
    pitch: Expr | None = None
    roll: Expr | None = None
    gripper: Literal["open", "closed"] | None = None


class MotionSpec(_Model):
    keypoints: list[KeypointSpec] | None = None
    spread: Expr | None = None
    spread_angle: Expr | None = None
    duration: Expr | None = None


class SolveSpec(_Model):
    """`solve d: Point minimize OBJ subject { ... }` as a mapping."""

    solve: Name
    type: TypeText
    minimize: Expr
    subject: ExprList | None = None


def _text_or(tag: str) -> Callable[[Any], str]:
    """A union's discriminator: a mapping is the model `tag`, anything else text."""
    return lambda value: tag if isinstance(value, dict) else "text"


# Tagged unions so that an error names one branch; tags are never YAML keys (see `_at`).
Argument = Annotated[Annotated[Expr, Tag("text")] | Annotated[SolveSpec, Tag("solve-spec")],
                     Discriminator(_text_or("solve-spec"))]
ParamValue = Annotated[Annotated[TypeText, Tag("text")] | Annotated[ParamSpec, Tag("param-spec")],
                       Discriminator(_text_or("param-spec"))]
_TAGS: dict[str, Any] = {"text": str, "solve-spec": SolveSpec, "param-spec": ParamSpec}


class PhaseSpec(_Model):
    name: Name
    primitive: Name
    roles: dict[Name, Name] | None = Field(None, description="Primitive role -> strategy role.")
    args: dict[Name, Argument] | None = Field(None, description="Primitive param -> value.")
    on_fail: Name | None = Field(None, description="`continue`: the strategy goes on after this "
                                                   "phase fails (default `stop`).")
    retry: Expr | None = Field(None, description="How many more times the phase is tried when it "
                                                 "fails (default 0, at most 5).")


class UseDecl(_Model):
    use: str = Field(description='`stdlib.push`, `stdlib.{push, flip}` or a file such as '
                                 '`lib/shelf.rapid`.')


class RelationDecl(_Model):
    relation: Name
    params: dict[Name, TypeText] | None = None
    body: Expr


class DefDecl(_Model):
    def_: Name = Field(alias="def")
    params: dict[Name, TypeText] | None = None
    returns: TypeText
    body: Expr


class PrimitiveDecl(_Model):
    primitive: Name
    goal: str
    roles: dict[Name, TypeText] | None = None
    requires: ExprList | None = None
    params: dict[Name, ParamValue] | None = None
    resolve: dict[Name, Expr] | None = Field(None, description="Features, evaluated in order.")
    success: ExprList | None = None
    cost: Cost | None = None
    motion: MotionSpec | None = None
    optimize: dict[Name, Expr] | None = None
    filter: ExprList | None = None


class StrategyDecl(_Model):
    strategy: Name
    goal: str
    roles: dict[Name, TypeText] | None = None
    requires: ExprList | None = None
    let: dict[Name, Expr] | None = None
    phases: list[PhaseSpec] | None = None
    success: ExprList | None = None
    filter: ExprList | None = None


_MODELS: dict[str, type[_Model]] = {"use": UseDecl, "relation": RelationDecl, "def": DefDecl,
                                    "primitive": PrimitiveDecl, "strategy": StrategyDecl}


def _declaration_kind(value: Any) -> str | None:
    found = [k for k in KINDS if isinstance(value, dict) and k in value]
    return found[0] if len(found) == 1 else None


Declaration = Annotated[
    Annotated[UseDecl, Tag("use")] | Annotated[RelationDecl, Tag("relation")]
    | Annotated[DefDecl, Tag("def")] | Annotated[PrimitiveDecl, Tag("primitive")]
    | Annotated[StrategyDecl, Tag("strategy")],
    Discriminator(_declaration_kind)]


def json_schema() -> dict[str, Any]:
    """JSON Schema (draft 2020-12) of a YAML program."""
    schema = TypeAdapter(list[Declaration]).json_schema()
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": SCHEMA_ID,
            "title": "RAPID program (YAML form)",
            "description": "A list of declarations; expressions are strings in .rapid syntax.",
            **schema}


# ------------------------------------------------------------------------- YAML with places

@dataclass(slots=True)
class _Node:
    """A YAML value (text, None, list or mapping) and where it is."""

    value: Any              # str | None | list[_Node] | dict[str, _Node]
    span: Span
    key_span: Span | None = None
    content: tuple[int, int] = (1, 1)   # where a scalar's text starts (after a quote)
    split_risk: bool = False    # a plain scalar in `[...]` or `{...}`: YAML ends it at a comma

    def plain(self) -> Any:
        if isinstance(self.value, list):
            return [item.plain() for item in self.value]
        if isinstance(self.value, dict):
            return {key: item.plain() for key, item in self.value.items()}
        return self.value


def _flow_depth(text: str) -> int:
    """Deepest nesting of `[` and `{` in the text; quotes are ignored, so it may overcount."""
    depth = deepest = 0
    for char in text:
        if char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}" and depth:
            depth -= 1
    return deepest


class _Limit(Exception):
    def __init__(self, message: str, span: Span) -> None:
        self.message, self.span = message, span


class _Loader:
    def __init__(self, text: str, path: str) -> None:
        self.text, self.path = text, path
        self.lines = text.split("\n")
        self.diagnostics: list[Diagnostic] = []
        self.count = 0

    def load(self) -> _Node | None:
        from ruamel.yaml import YAML
        from ruamel.yaml.error import YAMLError

        if _flow_depth(self.text) > MAX_DEPTH:
            # ruamel's scanner is quadratic in the depth of `[`/`{`: refuse before reading.
            self.diagnostics.append(error(
                E_YAML_LIMIT, f"the YAML nests `[` or `{{` deeper than {MAX_DEPTH} levels",
                Span.point(self.path)))
            return None
        yaml = YAML(typ="rt", pure=True)
        yaml.Scanner = counting_scanner(yaml.Scanner, MAX_TOKENS)
        try:
            root = yaml.compose(self.text)
        except TooManyTokens as limit:
            self.diagnostics.append(error(
                E_YAML_LIMIT, f"the YAML has more than {MAX_TOKENS} tokens",
                Span.point(self.path, limit.line, limit.column),
                help="split the program into files joined with `use`"))
            return None
        except YAMLError as exc:
            self.diagnostics.append(self._yaml_error(exc))
            return None
        except RecursionError:
            self.diagnostics.append(error(E_YAML_LIMIT, "the YAML nests too deeply to read",
                                          Span.point(self.path)))
            return None
        except Exception as exc:  # noqa: BLE001 - any reader failure on odd input is a diagnostic
            self.diagnostics.append(error(E_YAML_SYNTAX, f"cannot read the YAML: {exc}",
                                          Span.point(self.path)))
            return None
        if root is None:
            return None
        try:
            return self.node(root, 0, None)
        except _Limit as limit:
            self.diagnostics.append(error(E_YAML_LIMIT, limit.message, limit.span))
            return None

    def _yaml_error(self, exc: Exception) -> Diagnostic:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        position = getattr(exc, "position", None)   # a ReaderError (bad character) has only this
        if mark is not None:
            span = Span.point(self.path, mark.line + 1, mark.column + 1, mark.index)
        elif isinstance(position, int) and 0 <= position <= len(self.text):
            line = self.text.count("\n", 0, position) + 1
            col = position - (self.text.rfind("\n", 0, position) + 1) + 1
            span = Span.point(self.path, line, col, position)
        else:
            span = Span.point(self.path)
        problem = (getattr(exc, "problem", None)
                   or (str(exc).strip().splitlines() or ["unreadable input"])[0])
        context = getattr(exc, "context", None)
        message = f"{context}: {problem}" if context else str(problem)
        return error(E_YAML_SYNTAX, f"invalid YAML: {message}", span,
                     help="check indentation, colons and quotes around this place")

    def span(self, node: Any) -> Span:
        start, end = node.start_mark, node.end_mark
        return Span(self.path, start.index, end.index, start.line + 1, start.column + 1,
                    end.line + 1, end.column + 1)

    def node(self, node: Any, depth: int, key_span: Span | None, in_flow: bool = False) -> _Node:
        span = self.span(node)
        self.count += 1
        if depth > MAX_DEPTH:
            raise _Limit(f"the YAML nests deeper than {MAX_DEPTH} levels", span)
        if self.count > MAX_NODES:
            raise _Limit(f"the YAML has more than {MAX_NODES} values (aliases expand)", span)
        kind = node.id  # "scalar" | "sequence" | "mapping"
        if kind == "sequence":
            flow = bool(node.flow_style)
            return _Node([self.node(item, depth + 1, None, flow) for item in node.value], span,
                         key_span)
        if kind == "mapping":
            return _Node(self.mapping(node, depth), span, key_span)
        if node.tag.endswith(":null"):
            return _Node(None, span, key_span, (span.line, span.col))
        value, lone = _joined_surrogates(str(node.value))
        if lone is not None:   # no UTF-8 text (a `.rapid` file, the generated module) holds it
            self.diagnostics.append(error(
                E_YAML_TEXT, f"this text holds a lone surrogate (U+{ord(lone):04X}), "
                "which UTF-8 text cannot hold", span,
                help="write the character itself, or a pair of escapes for one outside the BMP"))
            return _Node("", span, key_span, self.content_start(node, span), False)
        return _Node(value, span, key_span, self.content_start(node, span),
                     in_flow and not node.style)

    def mapping(self, node: Any, depth: int) -> dict[str, _Node]:
        out: dict[str, _Node] = {}
        for key_node, value_node in node.value:
            key_span = self.span(key_node)
            if key_node.id != "scalar":
                self.diagnostics.append(error(E_YAML_SHAPE, "a key must be a plain word",
                                              key_span))
                continue
            key = str(key_node.value)
            if key in out:
                first = out[key].key_span or key_span
                self.diagnostics.append(error(
                    E_YAML_DUPLICATE_KEY, f"`{key}` appears twice in this mapping", key_span,
                    label="second time", related=[("first here", first)],
                    help="keep one of them"))
                continue
            out[key] = self.node(value_node, depth + 1, key_span, bool(node.flow_style))
        return out

    def content_start(self, node: Any, span: Span) -> tuple[int, int]:
        style = getattr(node, "style", None)
        if style in ('"', "'"):
            return span.line, span.col + 1
        if style in ("|", ">"):
            # The text starts on the next non-blank line, at that line's indentation.
            for number in range(span.line, min(span.end_line, len(self.lines))):
                line = self.lines[number]
                if line.strip():
                    return number + 1, len(line) - len(line.lstrip(" ")) + 1
        return span.line, span.col


# ------------------------------------------------------------------------------- validation

def _joined_surrogates(text: str) -> tuple[str, str | None]:
    """`text` with JSON-style escape pairs (`"\\ud83d\\ude00"`) joined into one character, and
    its first lone surrogate, if any is left."""
    if not _SURROGATE.search(text):
        return text, None
    pieces = _SURROGATE_PAIR.sub(
        lambda m: m[0].encode("utf-16-le", "surrogatepass").decode("utf-16-le"), text)
    lone = _SURROGATE.search(pieces)
    return pieces, lone[0] if lone else None


def _describe(kind: str, item: _Node) -> str:
    name = item.value.get(kind) if isinstance(item.value, dict) else None
    if name is not None and isinstance(name.value, str):
        return f"{kind} `{name.value}`"
    return kind


def _child(node: _Node, key: Any) -> _Node | None:
    value = node.value
    if isinstance(value, list) and isinstance(key, int):
        return value[key] if 0 <= key < len(value) else None
    if isinstance(value, dict) and isinstance(key, str):
        return value.get(key)
    return None


def _at(node: _Node, loc: tuple[Any, ...]) -> tuple[_Node, list[Any]]:
    """The deepest node along a pydantic error location, and the location steps not found."""
    rest = list(loc)
    while rest:
        key = rest[0]
        child = _child(node, key)
        if child is not None:
            node = child
        elif key in _TAGS:
            pass  # a union branch's tag, not a YAML key
        else:
            break
        rest.pop(0)
    return node, rest


def _model_keys(model: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """Keys allowed in the mapping at `loc` inside `model` (for "did you mean" help)."""
    current: Any = model
    for key in loc:
        if key in _TAGS:
            current = _TAGS[key]
            continue
        current = _unwrap(current)
        if isinstance(current, type) and issubclass(current, BaseModel):
            fields = {f.alias or n: f.annotation for n, f in current.model_fields.items()}
            if key in fields:
                current = fields[key]
                continue
            return []
        origin = typing.get_origin(current)
        if origin in (list, dict):
            current = typing.get_args(current)[-1]
            continue
        return []
    current = _unwrap(current)
    if isinstance(current, type) and issubclass(current, BaseModel):
        return [f.alias or n for n, f in current.model_fields.items()]
    return []


def _unwrap(annotation: Any) -> Any:
    """`X | None`, `Annotated[X, ...]` -> X; a union of a model and text -> the model."""
    while True:
        origin = typing.get_origin(annotation)
        if origin is Annotated:
            annotation = typing.get_args(annotation)[0]
        elif origin in (Union, types.UnionType):
            options = [a for a in typing.get_args(annotation) if a is not type(None)]
            models = [a for a in map(_unwrap, options)
                      if isinstance(a, type) and issubclass(a, BaseModel)]
            annotation = models[0] if models else options[0]
        else:
            return annotation


def _dotted(loc: tuple[Any, ...]) -> str:
    """`("motion", "keypoints", 0, "at")` -> `motion.keypoints[0].at` (tags left out)."""
    text = ""
    for key in loc:
        if isinstance(key, int):
            text += f"[{key}]"
        elif key not in _TAGS:
            text += ("." if text else "") + str(key)
    return text


_KIND_WORDS = {"string_type": "text (an expression, name or type)", "list_type": "a list",
               "dict_type": "a mapping (`key: value`)", "model_type": "a mapping (`key: value`)",
               "model_attributes_type": "a mapping (`key: value`)"}


def _found(node: _Node) -> str:
    if isinstance(node.value, list):
        return "a list"
    if isinstance(node.value, dict):
        return "a mapping"
    return "nothing" if node.value is None else f"`{node.value}`"


def _shape_errors(kind: str, item: _Node, exc: ValidationError, path: str) -> list[Diagnostic]:
    out: list[Diagnostic] = []
    seen: set[tuple[int, int, str]] = set()
    what = _describe(kind, item)
    for err in exc.errors():
        loc = tuple(err["loc"])
        node, rest = _at(item, loc)
        type_ = err["type"]
        code, span, help_text = E_YAML_SHAPE, node.span, None
        where = what if len(loc) == 1 else f"`{_dotted(loc[:-1])}` of {what}"
        if type_ == "missing":
            message = f"missing `{loc[-1]}` in {where}"
            span = Span.point(path, node.span.line, node.span.col, node.span.start)
        elif type_ == "extra_forbidden":
            key = str(loc[-1])
            span = node.key_span or node.span
            allowed = _model_keys(_MODELS[kind], loc[:-1])
            close = difflib.get_close_matches(key, allowed, n=1)
            message = f"unknown key `{key}` in {where}"
            help_text = (f"did you mean `{close[0]}`?" if close
                         else "allowed here: " + ", ".join(f"`{k}`" for k in allowed))
        elif rest == ["[key]"] or type_ == "string_pattern_mismatch":
            code = E_YAML_NAME
            bad = loc[-2] if rest == ["[key]"] else node.value
            if rest == ["[key]"]:
                span = node.key_span or node.span
            message = f"`{bad}` is not a name"
            help_text = "a name starts with a lower-case letter or `_` and goes on with " \
                        "letters, digits and `_`"
        elif type_ in _KIND_WORDS:
            message = f"expected {_KIND_WORDS[type_]} here, found {_found(node)}"
        elif type_ == "literal_error":
            message = f"{_found(node)} is not allowed here"
            help_text = f"write one of: {err.get('ctx', {}).get('expected', '')}"
        elif type_ in ("too_short", "too_long"):
            message = f"`{loc[-1]}` takes two values, found {len(node.value or [])}"
            help_text = "write `range: [LOW, HIGH]`"
        else:
            message = f"{err['msg'].rstrip('.')} at `{_dotted(loc)}` of {what}"
        place = (span.line, span.col, message)
        if place not in seen:
            seen.add(place)
            out.append(error(code, message, span, help=help_text))
    return out


# ------------------------------------------------------------------------------ AST building

@dataclass
class _Builder:
    path: str
    diagnostics: list[Diagnostic] = field(default_factory=list)
    complete: bool = True

    def fail(self, code: str, message: str, span: Span, help: str | None = None) -> None:
        self.diagnostics.append(error(code, message, span, help=help))
        self.complete = False

    def _parsed(self, parse: Callable[..., tuple[Any, list[Diagnostic]]], node: _Node) -> Any:
        line, col = node.content
        # rstrip: a block scalar (`|`) ends with a line break, which would end the expression.
        result, diagnostics = parse(str(node.value).rstrip(), self.path, line=line, col=col)
        if result is None:
            self.complete = False
            if node.split_risk and diagnostics and diagnostics[0].help is None:
                diagnostics[0] = replace(diagnostics[0], help=(
                    "inside `[...]` or `{...}` YAML ends a plain value at a comma: put the "
                    'expression in quotes, e.g. "on(box, table)"'))
        self.diagnostics.extend(diagnostics)
        return result

    def expr(self, node: _Node) -> Any:
        return self._parsed(parse_expression, node)

    def type(self, node: _Node) -> Any:
        return self._parsed(parse_type, node)

    def name(self, node: _Node) -> ast.Name:
        return ast.Name(str(node.value), node.span)

    def key(self, key: str, node: _Node) -> ast.Name:
        return ast.Name(key, node.key_span or node.span)

    def one_line(self, node: _Node, what: str) -> str:
        text = str(node.value)
        if "\n" in text or "\r" in text:
            self.fail(E_YAML_TEXT, f"{what} must be one line", node.span,
                      help="remove the line break (a block scalar `>-` folds lines into one)")
        return text

    def block(self, key: str, node: _Node) -> Span:
        start = node.key_span or node.span
        return start.to(node.span)

    def exprs(self, node: _Node) -> tuple[Any, ...]:
        return tuple(self.expr(item) for item in node.value)

    def typed(self, node: _Node | None) -> tuple[ast.TypedName, ...]:
        if node is None or node.value is None:
            return ()
        return tuple(ast.TypedName(self.key(k, v), self.type(v), self.block(k, v))
                     for k, v in node.value.items())

    # declarations -------------------------------------------------------------------------
    def declaration(self, kind: str, item: _Node) -> ast.Decl | None:
        fields: dict[str, _Node] = item.value
        span = item.span
        if kind == "use":
            return self.use(fields["use"], span)
        if kind == "relation":
            return ast.RelationDecl(self.name(fields["relation"]), self.typed(fields.get("params")),
                                    self.expr(fields["body"]), span)
        if kind == "def":
            return ast.DefDecl(self.name(fields["def"]), self.typed(fields.get("params")),
                               self.type(fields["returns"]), self.expr(fields["body"]), span)
        blocks: list[Any] = []
        handlers = self.primitive_blocks if kind == "primitive" else self.strategy_blocks
        for key, node in fields.items():
            if key != kind and node.value is not None:
                blocks.extend(handlers(key, node))
        cls = ast.Primitive if kind == "primitive" else ast.Strategy
        return cls(self.name(fields[kind]), tuple(blocks), span)

    _USE = re.compile(r"^\s*([a-z_]\w*(?:\s*\.\s*[a-z_]\w*)*)"
                      r"(?:\s*\.\s*\{\s*([a-z_]\w*(?:\s*,\s*[a-z_]\w*)*)\s*,?\s*\})?\s*$")

    def use(self, node: _Node, span: Span) -> ast.Use | None:
        text = str(node.value)
        if "/" in text or text.endswith((".rapid", ".yaml", ".yml")):
            return ast.Use(None, (), self.one_line(node, "a file path"), span)
        match = self._USE.match(text)
        if match is None or not match.group(2) and "." not in match.group(1):
            hint = (f"write `use: stdlib.{text.strip()}` or `use: {text.strip()}.rapid`"
                    if match else "write `stdlib.push`, `stdlib.{push, flip}` or a file path "
                                  "such as `lib/shelf.rapid`")
            self.fail("E0108" if match else E_YAML_SHAPE,
                      f"`use: {text}` names no declaration", node.span, help=hint)
            return None
        parts = [p.strip() for p in match.group(1).split(".")]
        if match.group(2):
            names = [n.strip() for n in match.group(2).split(",")]
            return ast.Use(tuple(parts), tuple(ast.Name(n, node.span) for n in names), None, span)
        return ast.Use(tuple(parts[:-1]), (ast.Name(parts[-1], node.span),), None, span)

    def common_block(self, key: str, node: _Node) -> list[Any] | None:
        span = self.block(key, node)
        if key == "goal":
            return [ast.Goal(self.one_line(node, "a goal"), span)]
        if key == "roles":
            return [ast.Roles(self.typed(node), span)]
        if key == "requires":
            return [ast.Requires(self.exprs(node), span)]
        if key == "success":
            return [ast.Success(self.exprs(node), span)]
        if key == "filter":
            return [ast.Filter(self.exprs(node), span)]
        return None

    def primitive_blocks(self, key: str, node: _Node) -> list[Any]:
        common = self.common_block(key, node)
        if common is not None:
            return common
        span = self.block(key, node)
        fields = node.value
        if key == "params":
            return [ast.Params(tuple(self.param(k, v) for k, v in fields.items()), span)]
        if key == "resolve":
            return [ast.Resolve(tuple(ast.Assign(self.key(k, v), self.expr(v), self.block(k, v))
                                      for k, v in fields.items()), span)]
        if key == "optimize":
            return [ast.Optimize(tuple(ast.Setting(self.key(k, v), self.expr(v), self.block(k, v))
                                       for k, v in fields.items()), span)]
        if key == "cost":
            return self.cost(node)
        assert key == "motion", key  # the model allows no other key
        return [self.motion(node, span)]

    def param(self, key: str, node: _Node) -> ast.ParamDecl:
        span = self.block(key, node)
        if isinstance(node.value, str):
            return ast.ParamDecl(self.key(key, node), self.type(node), span=span)
        fields = node.value
        low = high = None
        if fields.get("range") is not None:
            low, high = (self.expr(n) for n in fields["range"].value)
        default = fields.get("default")
        return ast.ParamDecl(self.key(key, node), self.type(fields["type"]), low, high,
                             self.expr(default) if default and default.value is not None else None,
                             span)

    def cost(self, node: _Node) -> list[Any]:
        out: list[Any] = []
        fields = {k: v for k, v in node.value.items() if v.value is not None}
        for key, value in fields.items():
            span = self.block(key, value)
            if key == "final":
                out.append(ast.CostFinal(self.expr(value), span))
            elif key == "progress":
                weight = fields.get("weight")
                out.append(ast.CostProgress(self.expr(weight) if weight else None,
                                            self.expr(value), span))
        if "weight" in fields and "progress" not in fields:
            self.fail(E_YAML_SHAPE, "`weight` weighs the progress cost, but there is no "
                                    "`progress`", fields["weight"].key_span or node.span,
                      help="add `progress: EXPRESSION` or remove `weight`")
        return out

    def motion(self, node: _Node, span: Span) -> ast.Motion:
        items: list[Any] = []
        for key, value in node.value.items():
            if value.value is None:
                continue
            if key == "keypoints":
                items.extend(self.keypoint(kp) for kp in value.value)
            else:
                items.append(ast.MotionSetting(key, self.expr(value), self.block(key, value)))
        return ast.Motion(tuple(items), span)

    def keypoint(self, node: _Node) -> ast.Keypoint:
        fields = node.value

        def optional(key: str) -> Any:
            value = fields.get(key)
            return self.expr(value) if value is not None and value.value is not None else None
        gripper = fields.get("gripper")
        return ast.Keypoint(self.name(fields["name"]), self.expr(fields["at"]), optional("yaw"),
                            optional("pitch"), gripper.value if gripper else None, node.span,
                            optional("roll"))

    def strategy_blocks(self, key: str, node: _Node) -> list[Any]:
        common = self.common_block(key, node)
        if common is not None:
            return common
        if key == "let":
            return [ast.Let(self.key(k, v), self.expr(v), self.block(k, v))
                    for k, v in node.value.items()]
        assert key == "phases", key
        return [self.phase(item) for item in node.value]

    def phase(self, node: _Node) -> ast.Phase:
        fields = node.value
        roles = fields.get("roles")
        args = fields.get("args")
        role_map = tuple(ast.RoleBinding(self.key(k, v), self.name(v), self.block(k, v))
                         for k, v in (roles.value or {}).items()) if roles else ()
        arguments = tuple(ast.Argument(self.key(k, v), self.argument(v), self.block(k, v))
                          for k, v in (args.value or {}).items()) if args else ()
        on_fail = self.name(fields["on_fail"]) if "on_fail" in fields else None
        retry = self.expr(fields["retry"]) if "retry" in fields else None
        return ast.Phase(self.name(fields["name"]), self.name(fields["primitive"]), role_map,
                         arguments, node.span, on_fail, retry)

    def argument(self, node: _Node) -> Any:
        if not isinstance(node.value, dict):
            return self.expr(node)
        fields = node.value
        subject = fields.get("subject")
        constraints = self.exprs(subject) if subject and subject.value is not None else ()
        return ast.Solve(self.name(fields["solve"]), self.type(fields["type"]),
                         self.expr(fields["minimize"]), constraints, node.span)


# ------------------------------------------------------------------------------------ entry

def parse_yaml_module(text: str, path: str) -> tuple[ast.Module | None, list[Diagnostic]]:
    """Parse a YAML program. Returns the module (None if it could not be built) and diagnostics."""
    loader = _Loader(text, path)
    root = loader.load()
    diagnostics = loader.diagnostics
    last = text.count("\n") + 1
    module_span = Span(path, 0, len(text), 1, 1, last, len(text) - text.rfind("\n"))
    if root is None or root.value is None:   # an empty document is an empty program
        if any(d.is_error for d in diagnostics):
            return None, diagnostics
        return ast.Module(path, (), module_span), diagnostics
    if not isinstance(root.value, list):
        diagnostics.append(error(
            E_YAML_SHAPE, f"a YAML program is a list of declarations, found {_found(root)}",
            root.span, help="start each declaration with `- `, e.g. `- primitive: NAME`"))
        return None, diagnostics
    builder = _Builder(path)
    complete = not any(d.is_error for d in diagnostics)
    decls: list[ast.Decl] = []
    for item in root.value:
        kind = _declaration_kind(item.plain() if isinstance(item.value, dict) else None)
        if kind is None:
            found = [k for k in KINDS if isinstance(item.value, dict) and k in item.value]
            diagnostics.append(error(
                E_YAML_DECLARATION,
                "a declaration has exactly one of the keys " + ", ".join(f"`{k}`" for k in KINDS)
                + (f"; this one has {', '.join(f'`{k}`' for k in found)}" if found
                   else f"; found {_found(item)}"),
                item.span, help="e.g. `- primitive: flip` followed by its blocks"))
            complete = False
            continue
        try:
            _MODELS[kind].model_validate(item.plain())
        except ValidationError as exc:
            diagnostics.extend(_shape_errors(kind, item, exc, path))
            complete = False
            continue
        decl = builder.declaration(kind, item)
        if decl is not None:
            decls.append(decl)
    diagnostics.extend(builder.diagnostics)
    if not (complete and builder.complete):
        return None, diagnostics
    return ast.Module(path, tuple(decls), module_span), diagnostics
