"""The models' complaints about a declaration, as diagnostics at the YAML node they are about."""


from __future__ import annotations

import difflib
import types
import typing
from typing import Annotated, Any, Union

from pydantic import (
    BaseModel,
    ValidationError,
)

from rapid_dsl.frontend.yaml.loader import _Node
from rapid_dsl.frontend.yaml.schema import _MODELS, _TAGS, E_YAML_NAME, E_YAML_SHAPE
from rapid_dsl.language.diagnostics import Diagnostic, Span, error


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
