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

`parse_yaml_module(text, path)` returns `(module | None, diagnostics)` like `parser.parse_module`:
loader.py reads the YAML with places, schema.py's models check each declaration's shape
(validation.py turns their complaints into diagnostics), and builder.py makes the syntax tree.
YAML is read node by node (ruamel.yaml's composer), so every value keeps its line and column; every
scalar is kept as the text written (`0.10` stays `0.10`), and expressions are parsed by
`parser.parse_expression` at their place in the file, so diagnostics point at YAML lines. The shape
(keys and kinds of values) is checked by pydantic models that also give the JSON Schema
(`json_schema()`, printed by `rapidc schema`). Nothing in a YAML file makes this module raise.

Positions inside an expression are exact for plain and quoted one-line scalars; in block scalars
(`|`, `>`) and scalars folded over several lines, only the first line's positions are exact.
"""


from __future__ import annotations

from pydantic import ValidationError

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.yaml.builder import _Builder
from rapid_dsl.frontend.yaml.loader import MAX_TOKENS, _Loader
from rapid_dsl.frontend.yaml.schema import (
    _MODELS,
    CODES,
    E_YAML_DECLARATION,
    E_YAML_SHAPE,
    KINDS,
    SCHEMA_ID,
    _declaration_kind,
    json_schema,
)
from rapid_dsl.frontend.yaml.validation import _found, _shape_errors
from rapid_dsl.language.diagnostics import Diagnostic, Span, error

__all__ = ["CODES", "MAX_TOKENS", "SCHEMA_ID", "json_schema", "parse_yaml_module"]


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
