"""Types of the language: entity kinds, quantities with dimensions, vectors, Bool.

Named `typesys` so it does not shadow the standard library's `types`.
"""

from __future__ import annotations

from dataclasses import dataclass

from rapid_dsl.language.kinds import KIND_PARENTS, is_subkind
from rapid_dsl.language.units import DIMENSIONLESS, Dim, dim_name

ENTITY_KINDS = tuple(KIND_PARENTS)  # Body, Object, Fixture, Surface, Manipulator


@dataclass(frozen=True, slots=True)
class EntityType:
    kind: str

    def __str__(self) -> str:
        return self.kind


@dataclass(frozen=True, slots=True)
class Quantity:
    dim: Dim

    def __str__(self) -> str:
        return dim_name(self.dim)


@dataclass(frozen=True, slots=True)
class VecType:
    dim: Dim

    def __str__(self) -> str:
        if self.dim == Dim(length=1):
            return "Point"
        if self.dim == DIMENSIONLESS:
            return "Direction"
        return f"Vec[{dim_name(self.dim)}]"


@dataclass(frozen=True, slots=True)
class BoolType:
    def __str__(self) -> str:
        return "Bool"


@dataclass(frozen=True, slots=True)
class ErrorType:
    """The type of an expression that already has an error: it matches anything, so one mistake
    gives one diagnostic, not a cascade."""

    def __str__(self) -> str:
        return "<error>"


Type = EntityType | Quantity | VecType | BoolType | ErrorType

BOOL = BoolType()
REAL = Quantity(DIMENSIONLESS)
ERROR = ErrorType()


def assignable(value: Type, target: Type) -> bool:
    """Can a value of type `value` stand where `target` is expected (entity subtyping)?"""
    if isinstance(value, ErrorType) or isinstance(target, ErrorType):
        return True
    if isinstance(value, EntityType) and isinstance(target, EntityType):
        return is_subkind(value.kind, target.kind)
    return value == target
