"""Expressions -> Python text: numpy over batched arrays, or CasADi inside `solve`.

Builtins are reached only as `B.<registry name>` (numpy) and `Y.<registry name>` (CasADi); the
language's operators become numpy arithmetic or `RT.<operator>`. Every function body gets a
`Scope` (program names -> Python names) and records in `Uses` what it read, so its prologue can
unpack exactly that.
"""

from __future__ import annotations

import keyword
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from rapid_dsl.compiler.constants import constant_text, fold_number, source_form
from rapid_dsl.compiler.errors import InternalCompilerError
from rapid_dsl.compiler.pretty import comment, literal, nesting
from rapid_dsl.frontend import ir
from rapid_dsl.frontend.tree import walk
from rapid_dsl.frontend.types import BoolType, Quantity, Type, VecType
from rapid_dsl.language.registry import BUILTINS

# Python operator precedence, enough to parenthesize only where needed.
ATOM, POW, UNARY, MUL, ADD, CMP = 100, 90, 80, 70, 60, 50
# Brackets one generated expression may nest: Python's parser takes at most 200 in a statement, so
# a deeper part goes into a temporary (`T1 = ...`) on a line of its own.
NESTING = 50


_NAME = re.compile(r"[a-z_][A-Za-z0-9_]*")


def python_identifier(name: str) -> str:
    """A program name as a Python identifier.

    Names the grammar admits are ASCII; a keyword gets a trailing `_`, and a name starting with
    `__` (which the loader refuses, as it would a dunder) a leading `U`.

    >>> python_identifier("lambda"), python_identifier("gap"), python_identifier("__class__")
    ('lambda_', 'gap', 'U__class__')
    """
    if not _NAME.fullmatch(name):
        raise InternalCompilerError(f"{name!r} is not a program name")
    if name.startswith("__"):
        return "U" + name
    return name + "_" if keyword.iskeyword(name) or keyword.issoftkeyword(name) else name


# ------------------------------------------------------------------------------------- names

class Scope:
    """Python names of one function: program names kept as they are unless they would clash."""

    def __init__(self, taken: Iterable[str]) -> None:
        self._taken = set(taken)
        self._names: dict[tuple[str, str], str] = {}

    def bind(self, kind: str, name: str) -> str:
        ident = python_identifier(name)
        while ident in self._taken:
            ident += "_"
        self._taken.add(ident)
        self._names[(kind, name)] = ident
        return ident

    def __getitem__(self, key: tuple[str, str]) -> str:
        try:
            return self._names[key]
        except KeyError:
            raise InternalCompilerError(f"no {key[0]} named `{key[1]}` in scope") from None


@dataclass
class Pending:
    """What the text lowered since `Expressions.take` needs beside its line: the notes of its
    constants, and the temporaries it reads (assignments that go before the line)."""

    notes: list[str] = field(default_factory=list)
    temps: list[str] = field(default_factory=list)
    count: int = 0                      # temporaries made in this function, for their names


@dataclass
class Uses:
    """What a function body read, so its prologue unpacks exactly that (in declaration order)."""

    frames: bool = False
    start: bool = False
    refs: set[tuple[str, str]] = field(default_factory=set)


# -------------------------------------------------------------------------------- expressions

class Expressions:
    """Lowers expressions of one function body to Python text."""

    def __init__(self, scope: Scope, uses: Uses, functions: Mapping[str, str],
                 definitions: Mapping[str, ir.Function], *,
                 features: Mapping[str, ir.Expr] | None = None) -> None:
        self.scope = scope
        self.uses = uses
        self.functions = functions           # def/relation name -> Python function name
        self.definitions = definitions       # def/relation name -> IR, to inline inside `solve`
        self.features = features or {}        # for inlining features inside `start(...)`
        self.pending = Pending()

    def take(self) -> tuple[tuple[str, ...], str]:
        """The temporaries and the end-of-line comment of the text lowered since the last call."""
        temps, note = tuple(self.pending.temps), comment(self.pending.notes)
        self.pending.temps.clear()
        self.pending.notes.clear()
        return temps, note

    # -- numeric (numpy) ----------------------------------------------------------------------

    def text(self, e: ir.Expr) -> str:
        return self.lower(e, start=False)[0]

    def clause(self, e: ir.Expr) -> str:
        """A success or filter clause: a top-level comparison keeps its sides for reports."""
        if isinstance(e, ir.Compare) and not isinstance(e.left.type, VecType):
            left, right = self.text(e.left), self.text(e.right)
            return f"RT.compare({left}, {literal(e.op)}, {right})"
        return self.text(e)

    def lower(self, e: ir.Expr, *, start: bool) -> tuple[str, int]:
        first = len(self.pending.notes)
        return self._bounded(*self._lower(e, start=start), first)

    def _bounded(self, text: str, prec: int, first: int) -> tuple[str, int]:
        """`text`, or a temporary holding it when it nests too deeply for one line (with the
        notes of its constants, those from index `first` on)."""
        if text.count("(") <= NESTING or nesting(text) <= NESTING:
            return text, prec
        self.pending.count += 1
        name = f"T{self.pending.count}"
        self.pending.temps.append(f"{name} = {text}{comment(self.pending.notes[first:])}")
        del self.pending.notes[first:]
        return name, ATOM

    def _lower(self, e: ir.Expr, *, start: bool) -> tuple[str, int]:
        frames = self._frames(start)
        if isinstance(e, ir.Binary | ir.Unary):
            folded = fold_number(e)
            if folded is not None:
                return self._constant(folded, e.type, "RT.vec")
        match e:
            case ir.Const(value=value):
                return self._constant(value, e.type, "RT.vec")
            case ir.Ref(kind="feature", name=name) if start:
                if name not in self.features:
                    raise InternalCompilerError(f"feature `{name}` has no definition")
                return self.lower(self.features[name], start=True)
            case ir.Ref(kind=kind, name=name):
                self.uses.refs.add((kind, name))
                return self.scope[(kind, name)], ATOM
            case ir.BuiltinCall(name=name, args=args):
                builtin = BUILTINS.get(name)
                if builtin is None:
                    raise InternalCompilerError(f"`{name}` is not in the builtin registry")
                if builtin.kind == "constant":
                    return f"B.{name}", ATOM
                self._use_frames(start)
                items = [frames, *(self.lower(a, start=start)[0] for a in args)]
                return f"B.{name}({', '.join(items)})", ATOM
            case ir.UserCall(name=name, args=args):
                self._use_frames(start)
                items = [frames, *(self.lower(a, start=start)[0] for a in args)]
                return f"{self._function(name)}({', '.join(items)})", ATOM
            case ir.Unary(op="-", operand=operand):
                return _negate(self.lower(operand, start=start))
            case ir.Unary(op="not", operand=operand):
                return f"RT.negate({self.lower(operand, start=start)[0]})", ATOM
            case ir.Binary(op=op, left=left, right=right):
                return self._binary(op, left, right, start)
            case ir.Compare(op=op, left=left, right=right):
                a, b = self.lower(left, start=start), self.lower(right, start=start)
                if isinstance(left.type, VecType):
                    equal = f"RT.vec_equal({a[0]}, {b[0]})"
                    if op == "==":
                        return equal, ATOM
                    if op == "!=":
                        return f"RT.negate({equal})", ATOM
                    raise InternalCompilerError(f"vectors compared with `{op}`")
                return f"{_paren(a, CMP + 1)} {op} {_paren(b, CMP + 1)}", CMP
            case ir.Logic(op=op, left=left, right=right):
                helper = "RT.both" if op == "and" else "RT.either"
                lhs, rhs = self.lower(left, start=start)[0], self.lower(right, start=start)[0]
                return f"{helper}({lhs}, {rhs})", ATOM
            case ir.If(cond=cond, then=then, orelse=orelse, type=type_):
                helper = "RT.where_vec" if isinstance(type_, VecType) else "RT.where"
                if not isinstance(type_, (VecType, Quantity, BoolType)):
                    raise InternalCompilerError(f"`if` of type {type_} cannot be compiled")
                parts = [self.lower(x, start=start)[0] for x in (cond, then, orelse)]
                return f"{helper}({', '.join(parts)})", ATOM
            case ir.Vector(items=items):
                parts = [self.lower(x, start=start)[0] for x in items]
                return f"RT.vec({', '.join(parts)})", ATOM
            case ir.Component(target=target, index=index):
                return f"RT.component({self.lower(target, start=start)[0]}, {index})", ATOM
            case ir.Start(expr=inner):
                return self.lower(inner, start=True)
        raise InternalCompilerError(f"cannot lower {type(e).__name__}")

    def _binary(self, op: str, left: ir.Expr, right: ir.Expr, start: bool) -> tuple[str, int]:
        a, b = self.lower(left, start=start), self.lower(right, start=start)
        left_vec, right_vec = isinstance(left.type, VecType), isinstance(right.type, VecType)
        if op == "*" and left_vec != right_vec:
            q, v = (b, a) if left_vec else (a, b)
            return f"RT.scale({q[0]}, {v[0]})", ATOM
        if op == "/" and left_vec and not right_vec:
            return f"RT.divide({a[0]}, {b[0]})", ATOM
        return _infix(op, a, b, right)

    def _constant(self, value: object, t: Type, vec: str) -> tuple[str, int]:
        if isinstance(t, Quantity | VecType) and isinstance(value, float | int | tuple) \
                and not isinstance(value, bool):
            shown = source_form(value, t.dim)
            if shown:
                self.pending.notes.append(shown)
        text = constant_text(value, vec)
        return text, (UNARY if text.startswith("-") else ATOM)

    def _frames(self, start: bool) -> str:
        return "F0" if start else "F"

    def _use_frames(self, start: bool) -> None:
        self.uses.frames = True
        self.uses.start |= start

    def _function(self, name: str) -> str:
        try:
            return self.functions[name]
        except KeyError:
            raise InternalCompilerError(f"no def or relation named `{name}`") from None

    # -- symbolic (CasADi, inside `solve`) -----------------------------------------------------

    def symbolic(self, e: ir.Expr, env: Mapping[str, tuple[str, bool]] | None = None,
                 ) -> tuple[str, int]:
        """CasADi text for e. `env` maps the `local` names of an inlined def to (text, symbolic):
        numpy text for arguments that do not depend on the solve variable, CasADi text otherwise.
        """
        first = len(self.pending.notes)
        return self._bounded(*self._symbolic(e, env or {}), first)

    def _symbolic(self, e: ir.Expr, env: Mapping[str, tuple[str, bool]]) -> tuple[str, int]:
        if not self.depends(e, env):
            if isinstance(e, ir.Const) and not isinstance(e.value, bool):
                return self._constant(e.value, e.type, "SV.vec")
            return f"SV.constant({self._numeric(e, env)})", ATOM
        match e:
            case ir.Ref(kind="solve_var", name=name):
                self.uses.refs.add(("solve_var", name))
                return self.scope[("solve_var", name)], ATOM
            case ir.Ref(kind="local", name=name) if name in env:
                return env[name][0], ATOM
            case ir.BuiltinCall(name=name, args=args):
                builtin = BUILTINS.get(name)
                if builtin is None or not builtin.symbolic:
                    raise InternalCompilerError(f"`{name}` has no symbolic form")
                items = [self.symbolic(a, env)[0] for a in args]
                return f"Y.{name}({', '.join(items)})", ATOM
            case ir.UserCall(name=name, args=args):
                function = self._definition(name)
                inner = {}
                for (param, _), arg in zip(function.params, args, strict=True):
                    if self.depends(arg, env):
                        inner[param] = (_paren(self.symbolic(arg, env), ATOM), True)
                    else:
                        inner[param] = (f"({self._numeric(arg, env)})", False)
                return f"({self.symbolic(function.body, inner)[0]})", ATOM
            case ir.Unary(op="-", operand=operand):
                return _negate(self.symbolic(operand, env))
            case ir.Binary(op=op, left=left, right=right):
                return _infix(op, self.symbolic(left, env), self.symbolic(right, env), right)
            case ir.Compare(op=op, left=left, right=right) if op != "!=":
                a, b = self.symbolic(left, env), self.symbolic(right, env)
                return f"{_paren(a, CMP + 1)} {op} {_paren(b, CMP + 1)}", CMP
            case ir.Vector(items=items):
                return f"SV.vec({', '.join(self.symbolic(x, env)[0] for x in items)})", ATOM
            case ir.Component(target=target, index=index):
                return f"SV.component({self.symbolic(target, env)[0]}, {index})", ATOM
        raise InternalCompilerError(f"{type(e).__name__} cannot depend on a solve variable")

    def depends(self, e: ir.Expr, env: Mapping[str, tuple[str, bool]]) -> bool:
        """Does e depend on the solve variable (directly or through an inlined def)?"""
        for node in walk(e):
            match node:
                case ir.Ref(kind="solve_var"):
                    return True
                case ir.Ref(kind="local", name=name) if name in env and env[name][1]:
                    return True
                case ir.UserCall(name=name, args=args) if any(self.depends(a, env) for a in args):
                    return True
        return False

    def _numeric(self, e: ir.Expr, env: Mapping[str, tuple[str, bool]]) -> str:
        numeric = {name: text for name, (text, symbolic) in env.items() if not symbolic}
        return _Substituted(self, numeric).lower(e, start=False)[0]

    def _definition(self, name: str) -> ir.Function:
        try:
            return self.definitions[name]
        except KeyError:
            raise InternalCompilerError(f"no def named `{name}`") from None


class _Substituted(Expressions):
    """Numeric lowering inside an inlined def: its `local` names stand for argument text."""

    def __init__(self, base: Expressions, env: Mapping[str, str]) -> None:
        super().__init__(base.scope, base.uses, base.functions, base.definitions,
                         features=base.features)
        self.pending = base.pending
        self.env = env

    def lower(self, e: ir.Expr, *, start: bool) -> tuple[str, int]:
        if isinstance(e, ir.Ref) and e.kind == "local" and e.name in self.env:
            return self.env[e.name], ATOM
        return super().lower(e, start=start)


def refs(exprs: Iterable[ir.Expr]) -> set[tuple[str, str]]:
    return {(n.kind, n.name) for e in exprs for n in walk(e) if isinstance(n, ir.Ref)}


def _paren(part: tuple[str, int], minimum: int) -> str:
    text, prec = part
    return text if prec >= minimum else f"({text})"


def _negate(part: tuple[str, int]) -> tuple[str, int]:
    text, prec = part
    if prec < UNARY or text.startswith("-"):
        text = f"({text})"
    return f"-{text}", UNARY


def _infix(op: str, a: tuple[str, int], b: tuple[str, int], right: ir.Expr) -> tuple[str, int]:
    if op == "^":
        if not (isinstance(right, ir.Const) and isinstance(right.value, float | int)
                and float(right.value).is_integer()):
            raise InternalCompilerError("`^` needs an integer constant exponent")
        exponent = int(right.value)
        power = str(exponent) if exponent >= 0 else f"({exponent})"
        return f"{_paren(a, ATOM)} ** {power}", POW
    prec = ADD if op in "+-" else MUL
    return f"{_paren(a, prec)} {op} {_paren(b, prec + 1)}", prec
