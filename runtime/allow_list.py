"""Check a generated module's syntax tree against the shapes the compiler emits, before it runs.

Program text is untrusted, so the loader does not rely on the compiler having escaped it well: a
module runs only if it is made of the compiler's own constructs. Its statements are the header
imports of `rapid_dsl.runtime.api.IMPORTS`, top-level plain functions (positional parameters, no
decorators or defaults), single-name assignments, `return`s and calls. Its expressions are calls,
names, constants (str, int, float, bool, None), tuples, dicts, subscripts and arithmetic and
comparison operators. Attributes are read only on a name: an imported name's API (`RT.vec`,
`B.distance`) or one of `VALUE_ATTRIBUTES` (`C.frames`, `F.first`, a solve problem's methods). No
name starts with `__`, and every name read is one the module defines (so no Python builtin).
"""

from __future__ import annotations

import ast

from rapid_dsl.language.limits import MAX_EXPONENT
from rapid_dsl.runtime.api import IMPORTS, VALUE_ATTRIBUTES

_EXPRESSION_NODES = (
    ast.Call, ast.Attribute, ast.Name, ast.Constant, ast.Tuple, ast.Dict, ast.Subscript,
    ast.BinOp, ast.UnaryOp, ast.Compare, ast.keyword, ast.Load,
    ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub,
    ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.Eq, ast.NotEq,
)
_CONSTANT_TYPES = (str, int, float, bool, type(None))
_HEADER = {(i.module, i.name, i.alias) for i in IMPORTS.values()}


class Refused(Exception):
    """A construct the compiler does not emit, at `line` of the module."""

    def __init__(self, line: int, reason: str) -> None:
        super().__init__(f"line {line}: {reason}")
        self.line = line
        self.reason = reason


def verify(tree: ast.Module) -> None:
    """Raise Refused for the first construct of `tree` outside the compiler's shapes."""
    defined = _defined(tree)
    for statement in tree.body:
        if isinstance(statement, ast.Import | ast.ImportFrom):
            _import(statement)
        elif isinstance(statement, ast.FunctionDef):
            _function(statement, defined)
        else:
            _statement(statement, defined)


def _defined(tree: ast.Module) -> set[str]:
    """Every name the module binds: imports, assignments, functions and their parameters."""
    names = {a.asname or a.name for s in tree.body if isinstance(s, ast.ImportFrom)
             for a in s.names}
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            names.add(node.name)
            names.update(a.arg for a in node.args.args)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
    return names


def _import(node: ast.Import | ast.ImportFrom) -> None:
    aliases = [(a.name, a.asname) for a in node.names]
    if isinstance(node, ast.ImportFrom) and node.level == 0 and len(aliases) == 1 and \
            (node.module, aliases[0][0], aliases[0][1]) in _HEADER:
        return
    names = ", ".join(name for name, _ in aliases)
    text = f"import {names}" if isinstance(node, ast.Import) else \
        f"from {'.' * node.level}{node.module or ''} import {names}"
    raise Refused(node.lineno, f"`{text}` is not one of the runtime's header imports; a compiled "
                  "program imports only " + "; ".join(f"`{i.line}`" for i in IMPORTS.values()))


def _function(node: ast.FunctionDef, defined: set[str]) -> None:
    args = node.args
    if node.decorator_list or args.posonlyargs or args.vararg or args.kwonlyargs or \
            args.kwarg or args.defaults or args.kw_defaults or getattr(node, "type_params", None):
        raise Refused(node.lineno, f"function `{node.name}` is not a plain function (no "
                      "decorators, defaults, type parameters, `*` or `**` parameters)")
    _identifier(node.name, node.lineno)
    _not_an_import(node.name, node.lineno)
    for arg in args.args:
        _identifier(arg.arg, arg.lineno)
        _not_an_import(arg.arg, arg.lineno)
        if arg.annotation is not None:
            _expression(arg.annotation, defined)
    if node.returns is not None:
        _expression(node.returns, defined)
    for statement in node.body:
        if isinstance(statement, ast.Return):
            if statement.value is not None:
                _expression(statement.value, defined)
        else:
            _statement(statement, defined)


def _statement(node: ast.stmt, defined: set[str]) -> None:
    """An assignment to one name, or an expression statement (a docstring or a call)."""
    if isinstance(node, ast.Assign):
        if len(node.targets) != 1 or not isinstance(node.targets[0], ast.Name):
            raise Refused(node.lineno, "an assignment must bind exactly one name")
        _identifier(node.targets[0].id, node.lineno)
        _not_an_import(node.targets[0].id, node.lineno)
        _expression(node.value, defined)
    elif isinstance(node, ast.Expr) and isinstance(node.value, ast.Call | ast.Constant):
        _expression(node.value, defined)
    elif isinstance(node, ast.Import | ast.ImportFrom):
        raise Refused(node.lineno, "an import inside a function is not allowed (a compiled "
                      "program imports only the runtime, at its top)")
    else:
        raise Refused(node.lineno, f"{_describe(node)} is not allowed in a compiled program")


def _expression(node: ast.expr, defined: set[str]) -> None:
    for inner in ast.walk(node):
        line = getattr(inner, "lineno", node.lineno)
        if not isinstance(inner, _EXPRESSION_NODES):
            raise Refused(line, f"{_describe(inner)} is not allowed in a compiled program")
        match inner:
            case ast.Name(id=name):
                _identifier(name, line)
                if name not in defined:
                    raise Refused(line, f"`{name}` is not defined in the module (a compiled "
                                  "program uses no Python builtins)")
            case ast.Attribute(value=value, attr=attr):
                _attribute(value, attr, line)
            case ast.Constant(value=value) if not isinstance(value, _CONSTANT_TYPES):
                raise Refused(line, f"a {type(value).__name__} constant is not allowed")
            case ast.keyword(arg=None):
                raise Refused(line, "`**` arguments are not allowed")
            case ast.Dict(keys=keys) if None in keys:
                raise Refused(line, "`**` in a dict is not allowed")
            case ast.BinOp():
                _arithmetic(inner, line)
            case ast.keyword(arg=str(arg)):
                _identifier(arg, line)


def _arithmetic(node: ast.BinOp, line: int) -> None:
    """Arithmetic as the compiler emits it, which cannot take long before anything runs: numbers
    only (no `"a" * 10 ** 9`), and `**` with a small integer exponent on a non-integer base
    (constants are folded by the checker, so a huge integer power never comes from a program)."""
    for operand in (node.left, node.right):
        if isinstance(operand, ast.Tuple | ast.Dict) or \
                isinstance(operand, ast.Constant) and not _is_number(operand.value):
            raise Refused(line, "arithmetic on something other than numbers is not allowed")
    if isinstance(node.op, ast.Pow):
        exponent = node.right
        if isinstance(exponent, ast.UnaryOp) and isinstance(exponent.op, ast.USub):
            exponent = exponent.operand
        if not (isinstance(exponent, ast.Constant) and type(exponent.value) is int
                and exponent.value <= MAX_EXPONENT):
            raise Refused(line, f"`**` takes an integer constant exponent of at most "
                          f"{MAX_EXPONENT}")
        if isinstance(node.left, ast.Constant) and type(node.left.value) is int:
            raise Refused(line, "`**` on an integer constant is not allowed")


def _is_number(value: object) -> bool:
    return type(value) in (int, float)


def _attribute(value: ast.expr, attr: str, line: int) -> None:
    if not isinstance(value, ast.Name):
        raise Refused(line, f"`.{attr}` is read on an expression; a compiled program reads "
                      "attributes only on names")
    imported = IMPORTS.get(value.id)
    if imported is not None:
        if attr not in imported.names:
            raise Refused(line, f"`{value.id}.{attr}`: `{attr}` is not part of the runtime API "
                          f"that `{value.id}` offers")
    elif attr not in VALUE_ATTRIBUTES:
        raise Refused(line, f"`{value.id}.{attr}`: a compiled program reads only the "
                      "attributes " + ", ".join(f"`{a}`" for a in sorted(VALUE_ATTRIBUTES))
                      + " of its values")


def _identifier(name: str, line: int) -> None:
    if name.startswith("__"):
        raise Refused(line, f"`{name}`: names starting with `__` are not allowed")


def _not_an_import(name: str, line: int) -> None:
    if name in IMPORTS:
        raise Refused(line, f"`{name}` names an imported part of the runtime; it cannot be "
                      "bound again")


def _describe(node: ast.AST) -> str:
    words = {"Lambda": "a lambda", "FunctionDef": "a nested function", "ClassDef": "a class",
             "AsyncFunctionDef": "an async function", "JoinedStr": "an f-string",
             "Starred": "a `*` argument", "NamedExpr": "`:=`"}
    name = type(node).__name__
    return words.get(name, f"`{name}`")

