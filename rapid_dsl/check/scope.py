"""What a name means at one point of a program: the value scope of an expression, names that exist
but are not visible there (with the reason), and the signatures of user functions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from rapid_dsl.check.types import SigType
from rapid_dsl.diagnostics import Span
from rapid_dsl.ir import RefKind
from rapid_dsl.modules import Entry
from rapid_dsl.typesys import Type


@dataclass(frozen=True, slots=True)
class Local:
    kind: RefKind
    name: str
    type: Type
    span: Span


@dataclass(frozen=True, slots=True)
class Hidden:
    """A name that exists in the declaration but may not be used here, and why."""

    code: str
    message: str
    help: str | None = None


@dataclass(slots=True)
class FuncSig:
    """A user `def` or `relation` as seen by its callers."""

    ir_name: str
    params: tuple[tuple[str, SigType], ...]
    returns: SigType
    is_relation: bool
    symbolic: bool = True       # set once the body is checked: may it take a `solve` variable?


@dataclass(slots=True)
class Globals:
    """The top level of one file: its own and its `use`d declarations."""

    entries: dict[str, Entry]
    function: Callable[[Entry], FuncSig | None]     # signature of a def/relation entry
    incomplete: bool = False                        # a failed `use`: unknown names may be its fault


@dataclass(slots=True)
class Env:
    """Everything an expression may refer to at one place."""

    globals: Globals
    scope: dict[str, Local] = field(default_factory=dict)
    hidden: dict[str, Hidden] = field(default_factory=dict)
    allow_start: bool = False
    solve_var: str | None = None

    def with_locals(self, *locals_: Local, hidden: dict[str, Hidden] | None = None) -> Env:
        scope = dict(self.scope)
        for local in locals_:
            scope[local.name] = local
        merged = {k: v for k, v in self.hidden.items() if k not in scope}
        merged.update(hidden or {})
        return Env(self.globals, scope, merged, self.allow_start, self.solve_var)
