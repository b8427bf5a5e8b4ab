"""Type checking of expressions: syntax.Expr -> ir.Expr with a type on every node.

An expression that has an error gets the type ERROR, which every rule accepts silently, so one
mistake gives one diagnostic. Names resolve first to the local scope (roles, params, features,
lets, keypoints, a solve variable), then to the registry's constants; calls resolve to user
`def`s and relations of the file, the registry's builtins and the special form `start(e)`.
"""

from __future__ import annotations

import math
from functools import partial
from itertools import islice

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.check.fold import Memo, fold
from rapid_dsl.frontend.check.scope import Env
from rapid_dsl.frontend.check.signatures import SigType, Unifier, builtin_signature
from rapid_dsl.frontend.check.text import bare_number, listing, short, suggest, with_unit
from rapid_dsl.frontend.modules import RESERVED, Entry
from rapid_dsl.frontend.tree import walk
from rapid_dsl.frontend.types import (
    BOOL,
    ERROR,
    BoolType,
    EntityType,
    ErrorType,
    Quantity,
    Type,
    VecType,
)
from rapid_dsl.language.diagnostics import Diagnostic, Span, error
from rapid_dsl.language.limits import MAX_EXPONENT
from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.language.units import UNITS, Dim

COMPONENTS = {"x": 0, "y": 1, "z": 2}

_SYMBOLIC = sorted(name for name, b in BUILTINS.items() if b.symbolic and b.kind == "function")
_CONSTANTS = [name for name, b in BUILTINS.items() if b.kind == "constant"]
_FUNCTIONS = [name for name, b in BUILTINS.items() if b.kind != "constant"]


def is_error(t: Type) -> bool:
    return isinstance(t, ErrorType)


def depends_on(expr: ir.Expr, kind: str) -> bool:
    """Does a `Ref` of this kind occur in `expr`?"""
    return any(isinstance(node, ir.Ref) and node.kind == kind for node in walk(expr))


class ExprChecker:
    """Checks expressions of one file; diagnostics accumulate in `self.diagnostics`."""

    def __init__(self, text: str, diagnostics: list[Diagnostic]) -> None:
        self.text = text
        self.diagnostics = diagnostics
        self.folded: Memo = {}      # constant values of the nodes built so far

    def err(self, code: str, message: str, span: Span, *, label: str | None = None,
            help: str | None = None, related: list[tuple[str, Span]] | None = None) -> None:
        self.diagnostics.append(error(code, message, span, label=label, help=help,
                                      related=related or []))

    def quote(self, node: ast.Expr) -> str:
        text = short(self.text, node.span)
        return f"`{text}`" if text else "the expression"

    # entry points --------------------------------------------------------------------------------
    def check(self, node: ast.Expr, env: Env) -> ir.Expr:
        """Recurses once per level (the parser refuses expressions deeper than
        parser.MAX_DEPTH)."""
        match node:
            case ast.Number():
                return self.number(node)
            case ast.Name():
                return self.name(node, env)
            case ast.Vector():
                return self.vector(node, env)
            case ast.Unary():
                return self.unary(node, env)
            case ast.Binary():
                return self.binary(node, env)
            case ast.Compare():
                return self.compare(node, env)
            case ast.Logic():
                return self.logic(node, env)
            case ast.IfExpr():
                return self.if_expr(node, env)
            case ast.Call():
                return self.call(node, env)
            case ast.Component():
                return self.component(node, env)
        raise AssertionError(f"unknown expression node {node!r}")

    def check_bool(self, node: ast.Expr, env: Env, what: str) -> ir.Expr:
        """An expression that must be Bool (`what` names the place, e.g. "a success clause")."""
        expr = self.check(node, env)
        if not isinstance(expr.type, (BoolType, ErrorType)):
            help_text = "compare it, e.g. `gap < 2cm`" if isinstance(expr.type, Quantity) else None
            self.err("E0307", f"{what} must be Bool, got {expr.type}", node.span,
                     help=help_text)
        return expr

    # atoms ----------------------------------------------------------------------------------------
    def number(self, node: ast.Number) -> ir.Expr:
        dim = UNITS[node.unit][0] if node.unit in UNITS else Dim()
        kind: ir.Type = Quantity(dim) if node.unit is None or node.unit in UNITS else ERROR
        if not math.isfinite(node.value):
            self.err("E0315", f"`{node.text}` is too large", node.span,
                     help="numbers are 64-bit floats, at most about 1.8e308")
            kind = ERROR
        return ir.Const(node.value, kind, node.span)

    def name(self, node: ast.Name, env: Env) -> ir.Expr:
        local = env.scope.get(node.name)
        if local is not None:
            return ir.Ref(local.kind, local.name, local.type, node.span)
        builtin = BUILTINS.get(node.name)
        if builtin is not None and builtin.kind == "constant":
            return ir.BuiltinCall(node.name, (), self.builtin_result(builtin), node.span)
        hidden = env.hidden.get(node.name)
        if hidden is not None:
            self.err(hidden.code, hidden.message, node.span, help=hidden.help)
        elif builtin is not None and _function_entry(env, node.name) is None:
            self.err("E0212", f"`{node.name}` is a {builtin.kind}, not a value", node.span,
                     help=f"call it: `{builtin.signature}`")
        elif node.name in env.globals.entries:
            decl = env.globals.entries[node.name].decl
            if isinstance(decl, (ast.Primitive, ast.Strategy)):
                self.err("E0213", f"`{node.name}` is a {_decl_kind(decl)}, not a value",
                         node.span, help="a strategy runs it in a `phase`")
            else:
                self.err("E0212", f"`{node.name}` is a {_decl_kind(decl)}, not a value",
                         node.span, help=f"call it: `{node.name}(...)`")
        elif node.name in RESERVED:
            self.err("E0212", f"`{node.name}` must be called: `{node.name}(expression)`",
                     node.span)
        else:
            self.err("E0201", f"unknown name `{node.name}`", node.span, help=env.globals.hints(
                lambda: suggest(node.name, [*env.scope, *_CONSTANTS])
                + f"names here: {listing(env.scope) or 'none'}"))
        return ir.Ref("local", node.name, ERROR, node.span)

    def vector(self, node: ast.Vector, env: Env) -> ir.Expr:
        items = [self.check(item, env) for item in node.items]
        if len(items) != 3:
            self.err("E0310", f"a vector has 3 items, this one has {len(items)}", node.span,
                     help="write `[x, y, z]`, e.g. `[1cm, 0cm, 2cm]`")
        dim: Dim | None = None
        ok = len(items) == 3
        for item, source in zip(items, node.items, strict=True):
            if is_error(item.type):
                ok = False
            elif not isinstance(item.type, Quantity):
                if ok:  # one report per vector is enough
                    self.err("E0311", f"vector items are quantities, not {item.type}",
                             source.span)
                ok = False
            elif dim is None:
                dim = item.type.dim
            elif item.type.dim != dim:
                hint = with_unit(source, dim)
                self.err("E0311", f"vector items have different dimensions: "
                         f"{Quantity(dim)} and {item.type}", source.span,
                         help=f"give every item the same unit, e.g. `{hint}`" if hint else
                         "give every item the same unit, e.g. `[1cm, 0cm, 2cm]`")
                ok = False
        padded = (items + [ir.Const(0.0, ERROR)] * 3)[:3]
        kind: Type = VecType(dim) if ok and dim is not None else ERROR
        return ir.Vector((padded[0], padded[1], padded[2]), kind, node.span)

    def component(self, node: ast.Component, env: Env) -> ir.Expr:
        target = self.check(node.target, env)
        field = node.field.name
        if field not in COMPONENTS:
            self.err("E0306", f"unknown component `.{field}`", node.field.span,
                     help="vectors have only `.x`, `.y` and `.z`")
            return ir.Component(target, 0, ERROR, node.span)
        index = COMPONENTS[field]
        if isinstance(target.type, VecType):
            return ir.Component(target, index, Quantity(target.type.dim), node.span)
        if not is_error(target.type):
            help_text = (f"for its position write `pos({short(self.text, node.target.span)})"
                         f".{field}`" if isinstance(target.type, EntityType) else None)
            self.err("E0312", f"`.{field}` needs a vector, got {target.type}", node.span,
                     help=help_text)
        return ir.Component(target, index, ERROR, node.span)

    # operators ------------------------------------------------------------------------------------
    def unary(self, node: ast.Unary, env: Env) -> ir.Expr:
        operand = self.check(node.operand, env)
        t = operand.type
        if node.op == "not":
            if not isinstance(t, (BoolType, ErrorType)):
                self.err("E0307", f"`not` needs a Bool, got {t}", node.operand.span)
                return ir.Unary("not", operand, ERROR, node.span)
            return ir.Unary("not", operand, BOOL if not is_error(t) else ERROR, node.span)
        if isinstance(t, (Quantity, VecType, ErrorType)):
            return ir.Unary("-", operand, t, node.span)
        self.err("E0309", f"`-` is not defined for {t}", node.span)
        return ir.Unary("-", operand, ERROR, node.span)

    def binary(self, node: ast.Binary, env: Env) -> ir.Expr:
        if node.op == "^":
            return self.power(node, env)
        left, right = self.check(node.left, env), self.check(node.right, env)
        a, b = left.type, right.type
        op = node.op
        result: Type = ERROR
        if is_error(a) or is_error(b):
            pass
        elif op in "+-":
            result = self.additive(node, a, b)
        elif op == "*":
            result = self.multiply(node, a, b)
        else:
            result = self.divide(node, a, b)
        out = ir.Binary(op, left, right, result, node.span)  # type: ignore[arg-type]
        return self.finite(out)

    def finite(self, expr: ir.Binary) -> ir.Expr:
        """Constant arithmetic must have a finite value (`1cm / 0`, `1e300 * 1e300` do not)."""
        memo = self.folded
        if is_error(expr.type) or fold(expr.left, memo) is None or \
                fold(expr.right, memo) is None or fold(expr, memo) is not None:
            return expr
        self.err("E0315", "this arithmetic on constants has no finite value", expr.span,
                 help="check for a division by zero or a number too large")
        return ir.Binary(expr.op, expr.left, expr.right, ERROR, expr.span)

    def additive(self, node: ast.Binary, a: Type, b: Type) -> Type:
        verb = "add" if node.op == "+" else "subtract"
        pair = f"{a} and {b}" if node.op == "+" else f"{b} from {a}"
        if isinstance(a, Quantity) and isinstance(b, Quantity) or \
                isinstance(a, VecType) and isinstance(b, VecType):
            if a == b:
                return a
            help_text = self.unit_help(node.left, node.right, a, b, "give the number a unit")
            if help_text is None and isinstance(a, VecType):
                help_text = "scale a Direction by a length to get a Point, e.g. `3cm * up`"
            self.err("E0301", f"cannot {verb} {pair}", node.span, help=help_text)
            return ERROR
        help_text = None
        if {type(a), type(b)} == {Quantity, VecType}:
            help_text = "use one component (`p.z + 1cm`) or scale a Direction (`1cm * up`)"
        elif isinstance(a, EntityType) or isinstance(b, EntityType):
            help_text = "an entity is not a value; e.g. `pos(box)` is its position"
        self.err("E0309", f"cannot {verb} {pair}", node.span, help=help_text)
        return ERROR

    def multiply(self, node: ast.Binary, a: Type, b: Type) -> Type:
        if isinstance(a, Quantity) and isinstance(b, Quantity):
            return Quantity(a.dim * b.dim)
        if isinstance(a, Quantity) and isinstance(b, VecType):
            return VecType(a.dim * b.dim)
        if isinstance(a, VecType) and isinstance(b, Quantity):
            return VecType(a.dim * b.dim)
        help_text = "use `dot(a, b)` or `cross(a, b)`" if isinstance(a, VecType) and \
            isinstance(b, VecType) else None
        self.err("E0309", f"cannot multiply {a} by {b}", node.span, help=help_text)
        return ERROR

    def divide(self, node: ast.Binary, a: Type, b: Type) -> Type:
        if isinstance(a, Quantity) and isinstance(b, Quantity):
            return Quantity(a.dim / b.dim)
        if isinstance(a, VecType) and isinstance(b, Quantity):
            return VecType(a.dim / b.dim)
        help_text = "divide by a scalar, e.g. `norm(v)`" if isinstance(b, VecType) else None
        self.err("E0309", f"cannot divide {a} by {b}", node.span, help=help_text)
        return ERROR

    def power(self, node: ast.Binary, env: Env) -> ir.Expr:
        base = self.check(node.left, env)
        exponent = _integer_literal(node.right)
        if exponent is None:
            self.err("E0304", "the exponent of `^` must be an integer literal", node.right.span,
                     help="write e.g. `x^2`; for a square root use `sqrt(x)`")
            return ir.Binary("^", base, ir.Const(1, ERROR, node.right.span), ERROR, node.span)
        if abs(exponent) > MAX_EXPONENT:
            self.err("E0304", f"the exponent of `^` must be an integer literal from "
                     f"-{MAX_EXPONENT} to {MAX_EXPONENT}", node.right.span,
                     help="a power this large has no finite value for any physical quantity")
            return ir.Binary("^", base, ir.Const(1, ERROR, node.right.span), ERROR, node.span)
        right = ir.Const(exponent, Quantity(Dim()), node.right.span)
        t = base.type
        if isinstance(t, Quantity):
            return self.finite(ir.Binary("^", base, right, Quantity(t.dim ** exponent), node.span))
        if not is_error(t):
            help_text = "for a vector's length use `norm(v)`" if isinstance(t, VecType) else None
            self.err("E0309", f"`^` is not defined for {t}", node.span, help=help_text)
        return ir.Binary("^", base, right, ERROR, node.span)

    def compare(self, node: ast.Compare, env: Env) -> ir.Expr:
        left, right = self.check(node.left, env), self.check(node.right, env)
        a, b = left.type, right.type
        out = ir.Compare(node.op, left, right, BOOL, node.span)  # type: ignore[arg-type]
        if is_error(a) or is_error(b):
            return out
        if isinstance(a, Quantity) and isinstance(b, Quantity):
            if a == b:
                return out
            self.compare_error(node, a, b)
            return out
        if node.op in ("==", "!=") and isinstance(a, BoolType) and isinstance(b, BoolType):
            return out
        if isinstance(a, VecType) and isinstance(b, VecType):
            self.err("E0309", f"vectors cannot be compared with `{node.op}`", node.span,
                     help="compare components (`p.z > 1cm`) or lengths (`norm(v) < 1cm`)")
        elif isinstance(a, EntityType) or isinstance(b, EntityType):
            self.err("E0309", f"entities cannot be compared with `{node.op}`", node.span,
                     help="compare their values, e.g. `height(a) > height(b)`")
        elif isinstance(a, BoolType) and isinstance(b, BoolType):
            self.err("E0309", f"Bool values have no order; `{node.op}` needs quantities",
                     node.span)
        else:
            self.compare_error(node, a, b)
        return out

    def compare_error(self, node: ast.Compare, a: Type, b: Type) -> None:
        # Label the side that is not a bare number (in `gap < 2` that is `gap`).
        side, side_type = (node.right, b) if bare_number(node.left) else (node.left, a)
        text = short(self.text, side.span)
        label = f"`{text}` is {_article(side_type)}" if text else None
        help_text = self.unit_help(node.left, node.right, a, b, "give the bound a unit")
        if help_text is None:
            help_text = "both sides of a comparison need the same dimension"
        self.err("E0302", f"cannot compare {a} with {b}", node.span, label=label, help=help_text)

    def unit_help(self, left: ast.Expr, right: ast.Expr, a: Type, b: Type,
                  prefix: str) -> str | None:
        """`give the bound a unit, e.g. `2cm`` when one side is a bare number."""
        for number, other in ((right, a), (left, b)):
            if isinstance(other, (Quantity, VecType)) and bare_number(number):
                written = with_unit(number, other.dim)
                if written:
                    return f"{prefix}, e.g. `{written}`"
        return None

    def logic(self, node: ast.Logic, env: Env) -> ir.Expr:
        left, right = self.check(node.left, env), self.check(node.right, env)
        ok = True
        for side, expr in ((node.left, left), (node.right, right)):
            if is_error(expr.type):
                ok = False
            elif not isinstance(expr.type, BoolType):
                self.err("E0307", f"`{node.op}` needs Bool operands, got {expr.type}", side.span)
                ok = False
        return ir.Logic(node.op, left, right, BOOL if ok else ERROR, node.span)  # type: ignore[arg-type]

    def if_expr(self, node: ast.IfExpr, env: Env) -> ir.Expr:
        cond = self.check_bool(node.cond, env, "the condition of `if`")
        then, orelse = self.check(node.then, env), self.check(node.orelse, env)
        a, b = then.type, orelse.type
        result: Type = ERROR
        if is_error(a) or is_error(b):
            pass
        elif a == b:
            result = a
        else:
            help_text = self.unit_help(node.then, node.orelse, a, b, "give the number a unit")
            self.err("E0313", f"the branches of `if` have different types: {a} and {b}",
                     node.span, help=help_text or "both branches need the same type")
        return ir.If(cond, then, orelse, result, node.span)

    # calls ----------------------------------------------------------------------------------------
    def call(self, node: ast.Call, env: Env) -> ir.Expr:
        name = node.func.name
        entry = env.globals.entries.get(name)
        builtin = BUILTINS.get(name)
        if builtin is not None and _function_entry(env, name) is None:
            entry = None  # a primitive or strategy never hides a builtin: phases run those
        if name in RESERVED:
            return self.start(node, env)
        if entry is not None and isinstance(entry.decl, (ast.RelationDecl, ast.DefDecl)):
            sig = env.globals.function(entry)
            if sig is None:
                self.check_args_only(node, env)
                return ir.UserCall(name, (), ERROR, node.span)
            args, given = self.bind(node, env, name, sig.params, sig.index)
            if args is None:
                return ir.UserCall(sig.ir_name, (), ERROR, node.span)
            result = self.apply(node, name, sig.params, sig.returns, args, given)
            if env.solve_var is not None and not sig.symbolic and not is_error(result) and \
                    any(depends_on(a, "solve_var") for a in args):
                self.err("E0318", f"`{name}` cannot take the solve variable `{env.solve_var}`",
                         node.span, help="its body uses builtins that have no symbolic form")
            return ir.UserCall(sig.ir_name, tuple(args), result, node.span)
        if entry is not None:
            self.check_args_only(node, env)
            self.err("E0213", f"`{name}` is a {_decl_kind(entry.decl)}, not a function",
                     node.func.span, help="a strategy runs a primitive in a `phase`")
            return ir.UserCall(name, (), ERROR, node.span)
        if builtin is not None and builtin.kind != "constant":
            signature = builtin_signature(builtin)
            args, given = self.bind(node, env, name, signature.params, signature.index)
            if args is None:
                return ir.BuiltinCall(name, (), ERROR, node.span)
            result = self.apply(node, name, signature.params, signature.returns, args, given)
            if env.solve_var is not None and not builtin.symbolic and not is_error(result) and \
                    any(depends_on(a, "solve_var") for a in args):
                self.err("E0318", f"`{name}` cannot take the solve variable `{env.solve_var}`",
                         node.span, help="inside a `solve` the variable may reach only "
                         + ", ".join(f"`{n}`" for n in _SYMBOLIC) + " and arithmetic")
            return ir.BuiltinCall(name, tuple(args), result, node.span)
        self.check_args_only(node, env)
        if builtin is not None:
            self.err("E0212", f"`{name}` is a constant, not a function", node.func.span,
                     help=f"write `{name}` without parentheses")
        elif name in env.scope:
            local = env.scope[name]
            self.err("E0212", f"`{name}` is a {_local_kind(local.kind)}, not a function",
                     node.func.span)
        elif not env.globals.incomplete:
            hint = env.globals.hints(lambda: suggest(
                name, [*_FUNCTIONS, *env.globals.functions, *RESERVED]), "")
            self.err("E0201", f"unknown function `{name}`", node.func.span,
                     help=f"{hint}functions are the builtins listed in docs/language.md and the "
                     "file's `def`s and relations")
        return ir.BuiltinCall(name, (), ERROR, node.span)

    def check_args_only(self, node: ast.Call, env: Env) -> None:
        for arg in node.args:
            self.check(arg.value, env)

    def start(self, node: ast.Call, env: Env) -> ir.Expr:
        if not env.allow_start:
            self.err("E0209", "`start(...)` is only available inside a primitive", node.func.span,
                     help="it is the value at the running primitive's first step")
        inner = Env(env.globals, env.scope, env.hidden, True, env.solve_var)
        values = [self.check(arg.value, inner) for arg in node.args]
        if len(node.args) != 1 or node.args[0].name is not None:
            self.err("E0510" if len(node.args) > 1 else "E0505",
                     "`start` takes one positional argument", node.span,
                     help="write `start(expression)`")
            return ir.Start(values[0] if values else ir.Const(0.0, ERROR), ERROR, node.span)
        return ir.Start(values[0], values[0].type, node.span)

    def bind(self, node: ast.Call, env: Env, name: str,
             params: tuple[tuple[str, SigType], ...], index: dict[str, int]
             ) -> tuple[list[ir.Expr] | None, dict[str, ast.Arg]]:
        """Check the arguments and put them in parameter order; None when one is missing.

        The work is that of the arguments given, not of the callee's parameter list (a call that
        gives 2 of 5,000 parameters costs 2 lookups), so many bad calls stay linear.
        """
        slots: dict[str, tuple[ast.Arg, ir.Expr]] = {}
        seen_keyword = misplaced = unknown = False
        for i, arg in enumerate(node.args):
            value = self.check(arg.value, env)
            if arg.name is None:
                if seen_keyword:
                    misplaced = True
                    self.err("E0511", "a positional argument cannot follow a keyword argument",
                             arg.span, help=f"write it as `name=...`; `{name}` takes "
                             + _param_names(params))
                    continue
                if i >= len(params):
                    self.err("E0510", f"`{name}` takes {len(params)} argument"
                             f"{'' if len(params) == 1 else 's'}, got {len(node.args)}", arg.span,
                             help=f"`{name}({_param_names(params)})`")
                    continue
                slots[params[i][0]] = (arg, value)
                continue
            seen_keyword = True
            key = arg.name.name
            if key not in index:
                unknown = True
                self.err("E0507", f"`{name}` has no parameter `{key}`", arg.name.span,
                         help=env.globals.hints(partial(_unknown_parameter, key, params)))
            elif key in slots:
                self.err("E0506", f"argument `{key}` of `{name}` is given twice", arg.span)
            else:
                slots[key] = (arg, value)
        given = {p: slot[0] for p, slot in slots.items()}
        if len(slots) == len(params):
            return [slots[p][1] for p, _ in params], given
        if not misplaced and not unknown:
            missing = list(islice((p for p, _ in params if p not in slots), 13))
            shown = ", ".join(f"`{p}`" for p in missing[:12]) + (", ..." if len(missing) > 12
                                                                  else "")
            self.err("E0505", f"`{name}` is missing argument{'s' if len(missing) > 1 else ''} "
                     f"{shown}", node.span,
                     help=f"`{name}({', '.join(f'{p}: {t}' for p, t in islice(params, 12))}"
                     f"{', ...' if len(params) > 12 else ''})`")
        return None, given

    def apply(self, node: ast.Call, name: str, params: tuple[tuple[str, SigType], ...],
              returns: SigType, args: list[ir.Expr], given: dict[str, ast.Arg]) -> Type:
        """Match argument types against the signature; the result type (ERROR on mismatch)."""
        unifier = Unifier()
        ok = True
        for (param, expected), value in zip(params, args, strict=True):
            if is_error(value.type):
                ok = False
                continue
            problem = unifier.match(param, expected, value.type)
            if problem is None:
                continue
            ok = False
            arg = given.get(param)
            span = arg.value.span if arg else node.span
            if problem == "wrong":
                help_text = None
                if arg is not None and expected.dim is not None and not expected.generic:
                    dim = Dim(*(int(e) for e in expected.dim.fixed))
                    written = with_unit(arg.value, dim)
                    help_text = f"give the number a unit, e.g. `{written}`" if written else None
                if expected.tag == "entity" and not isinstance(value.type, EntityType):
                    help_text = f"pass a role of kind {expected.kind}"
                self.err("E0303", f"argument `{param}` of `{name}` expects {expected}, "
                         f"got {value.type}", span, help=help_text)
            else:
                bound = problem.removeprefix("dimension of ")
                want = unifier.result(expected)
                self.err("E0317", f"argument `{param}` of `{name}` must have the {problem} "
                         f"({want}), got {value.type}", span,
                         help=f"`{name}` is generic: {bound} and `{param}` share one dimension")
        if not ok:
            return ERROR
        result = unifier.result(returns)
        if result == "not whole":
            self.err("E0317", f"`{name}` of {args[0].type} has no whole dimension", node.span,
                     help="take the square root of a squared quantity, e.g. `sqrt(x^2 + y^2)`")
            return ERROR
        assert not isinstance(result, str)
        return result

    def builtin_result(self, builtin: object) -> Type:
        from rapid_dsl.language.registry import Builtin
        assert isinstance(builtin, Builtin)
        result = Unifier().result(builtin_signature(builtin).returns)
        return ERROR if isinstance(result, str) else result


def _function_entry(env: Env, name: str) -> Entry | None:
    """The file's `def` or relation `name`: it wins over a builtin of that name (W0109)."""
    entry = env.globals.entries.get(name)
    return entry if entry is not None and isinstance(
        entry.decl, (ast.RelationDecl, ast.DefDecl)) else None


def _unknown_parameter(key: str, params: tuple[tuple[str, SigType], ...]) -> str:
    return suggest(key, (p for p, _ in params)) + "its parameters are: " + _param_names(params)


def _param_names(params: tuple[tuple[str, SigType], ...], limit: int = 12) -> str:
    """`a, b, c` (long lists cut with `...`)."""
    return ", ".join(p for p, _ in params[:limit]) + (", ..." if len(params) > limit else "")


def _integer_literal(node: ast.Expr) -> int | None:
    sign = 1
    if isinstance(node, ast.Unary) and node.op == "-":
        sign, node = -1, node.operand
    if isinstance(node, ast.Number) and node.unit is None and float(node.value).is_integer():
        return sign * int(node.value)
    return None


def _article(t: Type) -> str:
    text = str(t)
    return ("an " if text[:1] in "AEIOU" else "a ") + text


def _decl_kind(decl: object) -> str:
    return {ast.Primitive: "primitive", ast.Strategy: "strategy", ast.RelationDecl: "relation",
            ast.DefDecl: "def"}.get(type(decl), "declaration")


def _local_kind(kind: str) -> str:
    return {"role": "role", "param": "param", "feature": "resolved feature", "let": "let",
            "keypoint": "keypoint", "local": "parameter", "solve_var": "solve variable"}[kind]
