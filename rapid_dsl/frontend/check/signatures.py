"""Type expressions: the ones users write (`Length / Time`, `Vec[Angle]`) and the signature strings
of the builtin registry, which may also name dimension variables (`Q`, `Q1 * Q2`, `sqrt(Q)`).

A registry type becomes a `SigType` whose dimension is a pattern: fixed exponents plus a sum of
variables with (possibly fractional, for `sqrt`) coefficients. `Unifier` binds the variables from
the argument types, left to right, and gives the result type.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cache
from typing import Literal

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.modules import did_you_mean
from rapid_dsl.frontend.types import BOOL, ERROR, BoolType, EntityType, Quantity, Type, VecType
from rapid_dsl.language.diagnostics import Diagnostic, error
from rapid_dsl.language.kinds import KIND_PARENTS
from rapid_dsl.language.registry import Builtin
from rapid_dsl.language.units import DIMENSIONLESS, LENGTH, NAMED_DIMS, Dim

VALUE_TYPE_NAMES = ("Bool", *NAMED_DIMS, "Point", "Direction", "Vec")
TYPE_NAMES = (*KIND_PARENTS, *VALUE_TYPE_NAMES)

Exps = tuple[Fraction, Fraction, Fraction, Fraction]
_ZERO: Exps = (Fraction(0),) * 4  # type: ignore[assignment]


def _exps(dim: Dim) -> Exps:
    return tuple(Fraction(e) for e in dim.exponents)  # type: ignore[return-value]


def _add(a: Exps, b: Exps, k: Fraction = Fraction(1)) -> Exps:
    return tuple(x + k * y for x, y in zip(a, b, strict=True))  # type: ignore[return-value]


# ------------------------------------------------------------------------------ user types

def resolve_type(node: ast.TypeExpr, diagnostics: list[Diagnostic]) -> Type:
    """A written type to a `Type`; errors go to `diagnostics` and give `ERROR`."""
    match node:
        case ast.TypeName(name=name):
            if name in KIND_PARENTS:
                return EntityType(name)
            if name == "Bool":
                return BOOL
            if name in NAMED_DIMS:
                return Quantity(NAMED_DIMS[name])
            if name == "Point":
                return VecType(LENGTH)
            if name == "Direction":
                return VecType(DIMENSIONLESS)
            if name == "Vec":
                diagnostics.append(error("E0305", "`Vec` needs the type of its items", node.span,
                                         help="write e.g. `Vec[Length]`"))
                return ERROR
            hint = did_you_mean(name, TYPE_NAMES)
            diagnostics.append(error(
                "E0305", f"unknown type `{name}`", node.span,
                help=(hint + " " if hint else "") + "types are " + ", ".join(
                    f"`{t}`" for t in TYPE_NAMES if t != "Vec") + " and `Vec[Q]`"))
            return ERROR
        case ast.TypeApply(name=name, arg=arg):
            if name != "Vec":
                diagnostics.append(error("E0305", f"unknown type `{name}[...]`", node.span,
                                         help="the only type with an argument is `Vec[Q]`"))
                return ERROR
            item = resolve_type(arg, diagnostics)
            if isinstance(item, Quantity):
                return VecType(item.dim)
            if item is not ERROR:
                diagnostics.append(error("E0316", f"`Vec` holds quantities, not {item}", arg.span,
                                         help="write e.g. `Vec[Length]`"))
            return ERROR
        case ast.TypeBinary(op=op, left=left, right=right):
            a, b = resolve_type(left, diagnostics), resolve_type(right, diagnostics)
            if isinstance(a, Quantity) and isinstance(b, Quantity):
                return Quantity(a.dim * b.dim if op == "*" else a.dim / b.dim)
            for side, t in ((left, a), (right, b)):
                if t is not ERROR and not isinstance(t, Quantity):
                    diagnostics.append(error(
                        "E0316", f"only quantities can be multiplied or divided, not {t}",
                        side.span, help="e.g. `Length / Time`"))
            return ERROR
        case ast.TypePower(base=base, exponent=exponent):
            t = resolve_type(base, diagnostics)
            if isinstance(t, Quantity):
                return Quantity(t.dim ** exponent)
            if t is not ERROR:
                diagnostics.append(error("E0316", f"only quantities take a power, not {t}",
                                         base.span, help="e.g. `Length^2`"))
            return ERROR
    raise AssertionError(f"unknown type node {node!r}")


# -------------------------------------------------------------------------- registry types

@dataclass(frozen=True, slots=True)
class DimPattern:
    fixed: Exps
    vars: tuple[tuple[str, Fraction], ...] = ()

    def scaled(self, k: Fraction) -> DimPattern:
        fixed: Exps = tuple(e * k for e in self.fixed)  # type: ignore[assignment]
        return DimPattern(fixed, tuple((v, c * k) for v, c in self.vars))

    def times(self, other: DimPattern) -> DimPattern:
        coeffs: dict[str, Fraction] = dict(self.vars)
        for v, c in other.vars:
            coeffs[v] = coeffs.get(v, Fraction(0)) + c
        return DimPattern(_add(self.fixed, other.fixed),
                          tuple(sorted((v, c) for v, c in coeffs.items() if c)))


@dataclass(frozen=True, slots=True)
class SigType:
    tag: Literal["entity", "bool", "quantity", "vec"]
    kind: str = ""                      # for entities
    dim: DimPattern | None = None       # for quantities and vectors

    @property
    def generic(self) -> bool:
        return bool(self.dim and self.dim.vars)

    def __str__(self) -> str:
        return self.text

    @property
    def text(self) -> str:
        if self.tag == "entity":
            return self.kind
        if self.tag == "bool":
            return "Bool"
        assert self.dim is not None
        if not self.dim.vars:
            dim = Dim(*(int(e) for e in self.dim.fixed))
            return str(Quantity(dim) if self.tag == "quantity" else VecType(dim))
        name = " * ".join(v if c == 1 else f"{v}^{c}" for v, c in self.dim.vars)
        return name if self.tag == "quantity" else f"Vec[{name}]"


_TOKEN = re.compile(r"\s*(?:(\d+)|([A-Za-z_][A-Za-z0-9_]*)|([\[\]()*/^]))")
_VAR = re.compile(r"^Q\d*$")


class _SigParser:
    """Recursive descent over `Vec[Q1 * Q2]`, `sqrt(Q)`, `Length / Time`, `Object`, ..."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens: list[str] = []
        pos = 0
        while pos < len(text.rstrip()):
            m = _TOKEN.match(text, pos)
            if not m:
                raise ValueError(f"bad registry type {text!r}")
            self.tokens.append(m.group(m.lastindex or 0))
            pos = m.end()
        self.i = 0

    def peek(self) -> str | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def take(self, expected: str | None = None) -> str:
        tok = self.peek()
        if tok is None or (expected is not None and tok != expected):
            raise ValueError(f"bad registry type {self.text!r}")
        self.i += 1
        return tok

    def parse(self) -> SigType:
        result = self.product()
        if self.peek() is not None:
            raise ValueError(f"bad registry type {self.text!r}")
        return result

    def product(self) -> SigType:
        left = self.power()
        while self.peek() in ("*", "/"):
            op = self.take()
            right = self.power()
            if left.tag != "quantity" or right.tag != "quantity":
                raise ValueError(f"bad registry type {self.text!r}")
            assert left.dim is not None and right.dim is not None
            dim = right.dim if op == "*" else right.dim.scaled(Fraction(-1))
            left = SigType("quantity", dim=left.dim.times(dim))
        return left

    def power(self) -> SigType:
        base = self.atom()
        if self.peek() == "^":
            self.take()
            assert base.dim is not None
            base = SigType("quantity", dim=base.dim.scaled(Fraction(int(self.take()))))
        return base

    def atom(self) -> SigType:
        tok = self.take()
        if tok == "(":
            inner = self.product()
            self.take(")")
            return inner
        if tok == "sqrt":
            self.take("(")
            inner = self.product()
            self.take(")")
            assert inner.dim is not None
            return SigType("quantity", dim=inner.dim.scaled(Fraction(1, 2)))
        if tok == "Vec":
            self.take("[")
            inner = self.product()
            self.take("]")
            return SigType("vec", dim=inner.dim)
        if _VAR.match(tok):
            return SigType("quantity", dim=DimPattern(_ZERO, ((tok, Fraction(1)),)))
        if tok in KIND_PARENTS:
            return SigType("entity", kind=tok)
        if tok == "Bool":
            return SigType("bool")
        if tok in NAMED_DIMS:
            return SigType("quantity", dim=DimPattern(_exps(NAMED_DIMS[tok])))
        if tok == "Point":
            return SigType("vec", dim=DimPattern(_exps(LENGTH)))
        if tok == "Direction":
            return SigType("vec", dim=DimPattern(_ZERO))
        raise ValueError(f"bad registry type {self.text!r}")


@cache
def sig_type(text: str) -> SigType:
    """Parse a registry type string (cached: the registry is fixed for the process)."""
    return _SigParser(text).parse()


@dataclass(frozen=True, slots=True)
class Signature:
    params: tuple[tuple[str, SigType], ...]
    returns: SigType
    index: dict[str, int] = field(init=False, compare=False)    # param name -> position

    def __post_init__(self) -> None:
        object.__setattr__(self, "index", {p: i for i, (p, _) in enumerate(self.params)})


@cache
def builtin_signature(builtin: Builtin) -> Signature:
    return Signature(tuple((p.name, sig_type(p.type)) for p in builtin.params),
                     sig_type(builtin.returns))


def fixed_sig(t: Type) -> SigType | None:
    """The registry form of a concrete type (for user `def`s and relations)."""
    match t:
        case EntityType(kind=kind):
            return SigType("entity", kind=kind)
        case BoolType():
            return SigType("bool")
        case Quantity(dim=dim):
            return SigType("quantity", dim=DimPattern(_exps(dim)))
        case VecType(dim=dim):
            return SigType("vec", dim=DimPattern(_exps(dim)))
    return None


@dataclass(slots=True)
class Unifier:
    """Binds dimension variables from argument types, in argument order."""

    bindings: dict[str, Exps] = field(default_factory=dict)
    origin: dict[str, str] = field(default_factory=dict)   # variable -> the parameter that bound it

    def match(self, param: str, expected: SigType, actual: Type) -> str | None:
        """None if `actual` fits; otherwise why not ("wrong" = plain mismatch, or a message)."""
        if expected.tag == "entity":
            if isinstance(actual, EntityType) and actual.kind in _subkinds(expected.kind):
                return None
            return "wrong"
        if expected.tag == "bool":
            return None if isinstance(actual, BoolType) else "wrong"
        want_vec = expected.tag == "vec"
        if not isinstance(actual, VecType if want_vec else Quantity):
            return "wrong"
        assert expected.dim is not None
        got = _exps(actual.dim)
        fixed = expected.dim.fixed
        unbound = []
        for v, c in expected.dim.vars:
            if v in self.bindings:
                fixed = _add(fixed, self.bindings[v], c)
            else:
                unbound.append((v, c))
        if not unbound:
            if fixed == got:
                return None
            bound = [v for v, _ in expected.dim.vars if v in self.origin]
            if bound:
                return f"dimension of `{self.origin[bound[0]]}`"
            return "wrong"
        if len(unbound) > 1:
            return None  # cannot happen with the registry's signatures; accept rather than guess
        v, c = unbound[0]
        self.bindings[v] = tuple((g - f) / c for g, f in zip(got, fixed, strict=True))  # type: ignore[assignment]
        self.origin[v] = param
        return None

    def result(self, returns: SigType) -> Type | str:
        """The concrete result type, or a message when a dimension is not whole (odd `sqrt`)."""
        if returns.tag == "entity":
            return EntityType(returns.kind)
        if returns.tag == "bool":
            return BOOL
        assert returns.dim is not None
        exps = returns.dim.fixed
        for v, c in returns.dim.vars:
            if v not in self.bindings:
                return ERROR
            exps = _add(exps, self.bindings[v], c)
        if any(e.denominator != 1 for e in exps):
            return "not whole"
        dim = Dim(*(int(e) for e in exps))
        return VecType(dim) if returns.tag == "vec" else Quantity(dim)


@cache
def _subkinds(kind: str) -> frozenset[str]:
    return frozenset(k for k, parents in KIND_PARENTS.items() if k == kind or kind in parents)
