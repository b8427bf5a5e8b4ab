"""The API compiled programs target: declarations as data, an evaluation context, and operators.

A generated module (see `rapidc compile`) calls `require_abi`, defines plain functions over a
`Context`, and builds one `Program` from the dataclasses below. Builtins are reached only through
`NUMERIC` (the registry's numpy implementations, by registry name); the operators here (`scale`,
`both`, `where`, ...) are what the language's own operators become on batched arrays. Nothing here
knows how programs are executed: that is `rapid_dsl.runtime.executor`.

Array conventions (as in `rapid_dsl.runtime.builtins`): quantities are floats or arrays that
broadcast to (B, T), vectors to (B, T, 3), relations give bool (B, T); entities are int indices.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.runtime.builtins import IMPLEMENTATIONS
from rapid_dsl.runtime.frames import Frames

ABI = 1  # bump when the shape of generated modules changes

Value = Any            # float | np.ndarray | bool | int (entity index)
Features = Mapping[str, Value]
Clauses = tuple[Value, ...]

# The registry's numpy implementations under their registry names: `NUMERIC.distance(F, a, b)`.
NUMERIC = SimpleNamespace(**{name: IMPLEMENTATIONS[name] for name in sorted(BUILTINS)})


class AbiMismatch(RuntimeError):
    """A module generated for another version of the runtime."""


def require_abi(version: int) -> None:
    """Refuse a module generated for a different runtime ABI (recompile it with `rapidc`)."""
    if version != ABI:
        raise AbiMismatch(f"this program was compiled for runtime ABI {version}, but the runtime "
                          f"is ABI {ABI}: recompile it with this version of rapidc")


# ---------------------------------------------------------------------------------- evaluation

@dataclass(frozen=True, slots=True)
class Context:
    """What a compiled function reads: frames, role -> entity index, and named values."""

    frames: Frames
    roles: Mapping[str, int]
    params: Mapping[str, Value] = field(default_factory=dict)
    features: Mapping[str, Value] = field(default_factory=dict)
    lets: Mapping[str, Value] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Comparison:
    """A success, requires or filter clause that compares: its truth and the compared values."""

    holds: np.ndarray
    lhs: Value
    op: str
    rhs: Value


def compare(lhs: Value, op: str, rhs: Value) -> Comparison:
    """A top-level comparison clause, keeping its sides for reports."""
    return Comparison(_COMPARE[op](lhs, rhs), lhs, op, rhs)


_COMPARE: dict[str, Callable[[Value, Value], np.ndarray]] = {
    "<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal,
    "==": np.equal, "!=": np.not_equal,
}


def truth(clause: Value) -> np.ndarray:
    """A clause's value (Comparison or bool array) as a bool array."""
    if isinstance(clause, Comparison):
        return np.asarray(clause.holds, dtype=bool)
    return np.asarray(clause, dtype=bool)


# ----------------------------------------------------------------------------------- operators

def vec(x: Value, y: Value, z: Value) -> np.ndarray:
    """Vector literal `[x, y, z]` -> (..., 3)."""
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1).astype(float, copy=False)


def component(v: Value, index: int) -> Value:
    """`v.x`, `v.y`, `v.z` for index 0, 1, 2."""
    return np.asarray(v)[..., index]


def scale(q: Value, v: Value) -> np.ndarray:
    """`q * v` for a quantity q (..) and a vector v (.., 3)."""
    return np.asarray(q, dtype=float)[..., None] * np.asarray(v, dtype=float)


def divide(v: Value, q: Value) -> np.ndarray:
    """`v / q` for a vector v and a quantity q."""
    return np.asarray(v, dtype=float) / np.asarray(q, dtype=float)[..., None]


def both(a: Value, b: Value) -> np.ndarray:
    """`a and b`."""
    return np.logical_and(a, b)


def either(a: Value, b: Value) -> np.ndarray:
    """`a or b`."""
    return np.logical_or(a, b)


def negate(a: Value) -> np.ndarray:
    """`not a`."""
    return np.logical_not(a)


def where(cond: ArrayLike, then: ArrayLike, orelse: ArrayLike) -> np.ndarray:
    """`if cond then a else b` for quantities and Bools."""
    return np.where(cond, then, orelse)


def where_vec(cond: ArrayLike, then: ArrayLike, orelse: ArrayLike) -> np.ndarray:
    """`if cond then a else b` for vectors."""
    return np.where(np.asarray(cond)[..., None], then, orelse)


def vec_equal(a: Value, b: Value) -> np.ndarray:
    """`a == b` for vectors: every component equal."""
    return np.all(np.asarray(a) == np.asarray(b), axis=-1)


# -------------------------------------------------------------------------------- declarations

@dataclass(frozen=True, slots=True)
class Role:
    name: str
    kind: str                   # Body | Object | Fixture | Surface | Manipulator


@dataclass(frozen=True, slots=True)
class Param:
    """An effect parameter. `type` is the language's type text; values are SI."""

    name: str
    type: str                   # Length, Angle, Point, Direction, Real, ...
    shape: Literal["scalar", "vector", "bool"]
    low: float | None = None    # inclusive; for a vector, bounds on its norm
    high: float | None = None
    has_default: bool = False
    unit: str = ""              # SI unit symbol of the type's dimension, for reports


@dataclass(frozen=True, slots=True)
class Requirement:
    """One `requires` clause: a relation over the roles it names, `test(F, *entity_indices)`."""

    text: str
    origin: str                 # "file.rapid:LINE"
    roles: tuple[str, ...]
    test: Callable[..., Value]


@dataclass(frozen=True, slots=True)
class ClauseInfo:
    text: str
    origin: str
    unit: str = ""              # unit of a comparison's sides ("" for Bool clauses)


@dataclass(frozen=True, slots=True)
class Checks:
    """A success or filter block: `evaluate(ctx)` returns one value per clause, in order."""

    clauses: tuple[ClauseInfo, ...]
    evaluate: Callable[[Context], Clauses]


def _no_clauses(context: Context) -> Clauses:
    return ()


NO_CHECKS = Checks((), _no_clauses)


@dataclass(frozen=True, slots=True)
class Keypoint:
    """A keypoint's value in the primitive's start state (B=1, T=1 arrays are fine)."""

    name: str
    position: Value             # (.., 3) [m]
    yaw: Value | None = None    # [rad]
    pitch: Value | None = None  # [rad]
    grip: float | None = None   # 0 open, 1 closed; None keeps the previous command
    roll: Value | None = None   # [rad], about the approach axis after yaw and pitch


Keypoints = tuple[Keypoint, ...]


@dataclass(frozen=True, slots=True)
class Motion:
    keypoints: Callable[[Context], Keypoints]
    names: tuple[str, ...]
    spread: float               # std of position offsets [m]
    spread_angle: float         # std of yaw/pitch/roll offsets [rad]
    duration: float             # time to pass through every keypoint [s]


@dataclass(frozen=True, slots=True)
class Optimize:
    samples: int
    elites: int
    iterations: int
    seed: int | None = None


@dataclass(frozen=True, slots=True)
class Primitive:
    name: str
    goal: str
    origin: str
    roles: tuple[Role, ...]
    params: tuple[Param, ...]
    requires: tuple[Requirement, ...]
    defaults: Callable[[Context], dict[str, Value]] | None
    features: Callable[[Context], dict[str, Value]]
    success: Checks
    cost_final: Callable[[Context], Value]
    cost_progress: Callable[[Context], Value] | None
    progress_weight: float
    motion: Motion
    optimize: Optimize
    filter: Checks


@dataclass(frozen=True, slots=True)
class Phase:
    name: str
    primitive: str
    origin: str
    role_map: tuple[tuple[str, str], ...]     # (primitive role, strategy role)
    arguments: Callable[[Context], dict[str, Value]] | None
    argument_names: tuple[str, ...]
    argument_origins: tuple[str, ...]
    unchecked_requires: tuple[Requirement, ...]   # primitive requires the strategy does not
                                                  # state, over the strategy's roles
    on_fail: Literal["stop", "continue"] = "stop"  # continue: the strategy goes on after a failure
    retry: int = 0                                 # further attempts after a failed one


@dataclass(frozen=True, slots=True)
class Strategy:
    name: str
    goal: str
    origin: str
    roles: tuple[Role, ...]
    requires: tuple[Requirement, ...]
    lets: Callable[[Context], dict[str, Value]] | None
    phases: tuple[Phase, ...]
    success: Checks
    filter: Checks


@dataclass(frozen=True, slots=True)
class Program:
    path: str
    primitives: tuple[Primitive, ...]
    strategies: tuple[Strategy, ...]
    own: tuple[str, ...]                      # declarations of the file itself, in source order

    def primitive(self, name: str) -> Primitive:
        for primitive in self.primitives:
            if primitive.name == name:
                return primitive
        raise KeyError(name)

    def strategy(self, name: str) -> Strategy:
        for strategy in self.strategies:
            if strategy.name == name:
                return strategy
        raise KeyError(name)

    def declaration(self, name: str) -> Primitive | Strategy:
        decls: tuple[Primitive | Strategy, ...] = (*self.strategies, *self.primitives)
        for decl in decls:
            if decl.name == name:
                return decl
        raise KeyError(name)


# ------------------------------------------------------------------------------- line mapping

# A generated module names its source files once, in `SOURCES = ("file.rapid", ...)`; a marker
# comment above a statement holds only an index into it and a line number, never a file name.
_MARKER = re.compile(r"^[ ]*# SOURCES\[(?P<index>\d+)\]:(?P<line>\d+)$")


def marker(index: int, line: int) -> str:
    """The comment that maps the statements below it to line `line` of `SOURCES[index]`."""
    return f"# SOURCES[{index}]:{line}"


def markers(source: str) -> Iterator[tuple[int, int, int]]:
    """(generated line, source index, source line) of every marker, in generated-line order."""
    for number, text in enumerate(source.split("\n"), start=1):
        match = _MARKER.match(text)
        if match:
            yield number, int(match["index"]), int(match["line"])


def origin_of(source: str, line: int, sources: tuple[str, ...]) -> str | None:
    """The `.rapid` location (`FILE:LINE`) of a generated line: the nearest marker at or above."""
    found = None
    for number, index, source_line in markers(source):
        if number > line:
            break
        found = (index, source_line)
    if found is None or found[0] >= len(sources):
        return None
    return f"{sources[found[0]]}:{found[1]}"
