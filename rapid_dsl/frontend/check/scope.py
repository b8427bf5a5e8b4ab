"""What a name means at one point of a program: the value scope of an expression, names that exist
but are not visible there (with the reason), and the signatures of user functions.
"""

from __future__ import annotations

from collections import ChainMap
from collections.abc import Callable, Iterator, Mapping, MutableMapping
from dataclasses import dataclass, field

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.check.signatures import SigType
from rapid_dsl.frontend.check.text import Hints
from rapid_dsl.frontend.ir import RefKind
from rapid_dsl.frontend.modules import Entry
from rapid_dsl.frontend.types import Type
from rapid_dsl.language.diagnostics import Span


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
    index: dict[str, int] = field(init=False)    # param name -> position

    def __post_init__(self) -> None:
        self.index = {p: i for i, (p, _) in enumerate(self.params)}


@dataclass(slots=True)
class Globals:
    """The top level of one file: its own and its `use`d declarations."""

    entries: dict[str, Entry]
    function: Callable[[Entry], FuncSig | None]     # signature of a def/relation entry
    incomplete: bool = False                        # a failed `use`: unknown names may be its fault
    hints: Hints = field(default_factory=Hints)     # the file's budget of name-searching help
    primitives: list[str] = field(default_factory=list)     # names of the primitive entries
    functions: list[str] = field(default_factory=list)      # names of the def/relation entries

    def __post_init__(self) -> None:
        for name, entry in self.entries.items():
            if isinstance(entry.decl, ast.Primitive):
                self.primitives.append(name)
            elif isinstance(entry.decl, (ast.RelationDecl, ast.DefDecl)):
                self.functions.append(name)


class Layers(Mapping[str, Hidden]):
    """Two tables of hidden names read as one; `top` wins. Both stay live (not copied)."""

    __slots__ = ("top", "rest")

    def __init__(self, top: Mapping[str, Hidden], rest: Mapping[str, Hidden]) -> None:
        self.top = top
        self.rest = rest

    def __getitem__(self, name: str) -> Hidden:
        found = self.top.get(name)
        return found if found is not None else self.rest[name]

    def __iter__(self) -> Iterator[str]:
        return iter({**dict.fromkeys(self.rest), **dict.fromkeys(self.top)})

    def __len__(self) -> int:
        return len({**dict.fromkeys(self.rest), **dict.fromkeys(self.top)})


@dataclass(slots=True)
class Env:
    """Everything an expression may refer to at one place.

    A name in `scope` always wins over the same name in `hidden`, so hidden tables need not be
    pruned when names are defined. Making an Env costs the size of what is added, never the size
    of a shared table: checking a declaration with n names stays O(n).
    """

    globals: Globals
    scope: MutableMapping[str, Local] = field(default_factory=dict)
    hidden: Mapping[str, Hidden] = field(default_factory=dict)
    allow_start: bool = False
    solve_var: str | None = None

    def with_locals(self, *locals_: Local, hidden: Mapping[str, Hidden] | None = None) -> Env:
        """A new scope: this one's names, then `locals_` (a copy: use it once per block)."""
        env = self.child(hidden)
        for local in locals_:
            env.define(local)
        return env

    def child(self, hidden: Mapping[str, Hidden] | None = None) -> Env:
        """A copy with a scope table of its own, for `define`; `hidden` (kept live, not copied)
        goes over this one's hidden names."""
        return Env(self.globals, dict(self.scope),
                   Layers(hidden, self.hidden) if hidden is not None else self.hidden,
                   self.allow_start, self.solve_var)

    def inner(self, local: Local) -> Env:
        """A scope of one more name over this one, sharing its table (for a `solve` variable)."""
        return Env(self.globals, ChainMap({local.name: local}, self.scope), self.hidden,
                   self.allow_start, self.solve_var)

    def define(self, local: Local) -> None:
        """Add a name to this scope in place (the next definition of a run sees it)."""
        self.scope[local.name] = local
