"""The YAML nodes of a declaration that fits the models -> the syntax tree, each expression parsed
at its place in the file."""


from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.parser import parse_expression, parse_type
from rapid_dsl.frontend.yaml.loader import _Node
from rapid_dsl.frontend.yaml.schema import E_YAML_SHAPE, E_YAML_TEXT
from rapid_dsl.language.diagnostics import Diagnostic, Span, error


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
