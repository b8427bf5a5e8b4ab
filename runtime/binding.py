"""Binding: type-compatible, injective assignments of scene entities to roles that satisfy Gamma.

Bind_E(r, Gamma) of the paper. Candidates for a role are the entities whose kind is a subkind of the
role's kind, in entity order; roles are filled in declaration order by backtracking, and a relation
is checked as soon as all its roles are filled, so bindings come out in lexicographic order of
their entity indices. Relations are evaluated on `frames` (normally B=1, T=1: the current state)
and must hold at every recorded sample and time point.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from itertools import islice, product

import numpy as np

from rapid_dsl.runtime.builtins import IMPLEMENTATIONS
from rapid_dsl.runtime.frames import KIND_PARENTS, Frames, is_subkind
from rapid_dsl.runtime.registry import BUILTINS

Role = tuple[str, str]                      # (role name, kind)
Requirement = tuple[str, tuple[str, ...]]   # (relation name, role names)
RelationImpl = Callable[..., np.ndarray]

_EXAMPLES = 4  # candidate tuples quoted per relation in explanations


class BindingError(ValueError):
    """The roles, requirements or pins are malformed (not merely unsatisfiable)."""


def bind(
    roles: Sequence[Role],
    requires: Sequence[Requirement],
    frames: Frames,
    *,
    fixed: Mapping[str, str] | None = None,
    relations: Mapping[str, RelationImpl] | None = None,
    limit: int | None = None,
) -> list[dict[str, str]]:
    """Every binding {role: entity name} of the scene in `frames`, in deterministic order.

    `fixed` pins roles to entity names (from `--bind role=name`); `relations` adds implementations
    (e.g. compiled derived relations) to the builtin ones, called as `impl(frames, *indices)`;
    `limit` stops after that many bindings. Raises BindingError for malformed input.
    """
    problem = _Problem(roles, requires, frames, fixed or {}, relations or {})
    return [problem.named(choice) for choice in islice(problem.search(), limit)]


def explain_no_binding(
    roles: Sequence[Role],
    requires: Sequence[Requirement],
    frames: Frames,
    *,
    fixed: Mapping[str, str] | None = None,
    relations: Mapping[str, RelationImpl] | None = None,
) -> str:
    """A readable reason why `bind` finds nothing: missing kinds, or which relation failed."""
    problem = _Problem(roles, requires, frames, fixed or {}, relations or {})
    lines = [f"role `{name}: {kind}` has no candidate (the scene has no entity of kind {kind})"
             for name, kind in problem.roles if not problem.candidates[name]]
    if lines:
        return "no binding: " + "; ".join(lines)
    if next(problem.search(check=False), None) is None:
        wanted = ", ".join(f"{name}: {kind}" for name, kind in problem.roles)
        return f"no binding: the scene has too few distinct entities for the roles ({wanted})"
    for relation, args in problem.requires:
        tuples = list(problem.tuples(args))
        if not any(problem.holds(relation, t) for t in tuples):
            call = f"{relation}({', '.join(args)})"
            lines.append(f"{call} is false for every candidate: {problem.quote(args, tuples)}")
    if lines:
        return "no binding: " + "; ".join(lines)
    if next(problem.search(), None) is not None:
        return "a binding exists"
    parts = []
    for relation, args in problem.requires:
        holding = [t for t in problem.tuples(args) if problem.holds(relation, t)]
        parts.append(f"{relation}({', '.join(args)}) holds only for {problem.quote(args, holding)}")
    return ("no binding: each relation holds for some entities but no single injective assignment "
            "satisfies all of them together; " + "; ".join(parts))


class _Problem:
    """Validated roles, candidates and a memo of relation values."""

    def __init__(
        self,
        roles: Sequence[Role],
        requires: Sequence[Requirement],
        frames: Frames,
        fixed: Mapping[str, str],
        relations: Mapping[str, RelationImpl],
    ) -> None:
        self.frames = frames
        self.entities = frames.entities.entities
        self.roles = [(str(name), str(kind)) for name, kind in roles]
        self.requires = [(str(rel), tuple(args)) for rel, args in requires]
        self.fixed = dict(fixed)
        builtin = {n: IMPLEMENTATIONS[n] for n, b in BUILTINS.items() if b.kind == "relation"}
        self.impls = {**builtin, **relations}
        self.custom = set(relations)
        self.position = {name: i for i, (name, _) in enumerate(self.roles)}
        self._memo: dict[tuple[str, tuple[int, ...]], bool] = {}
        self._validate()
        self.candidates = {name: self._candidates(name, kind) for name, kind in self.roles}
        # Check each relation right after the last of its roles is filled.
        self.due: list[list[Requirement]] = [[] for _ in self.roles]
        for rel, args in self.requires:
            self.due[max((self.position[a] for a in args), default=0)].append((rel, args))

    def _validate(self) -> None:
        names = [name for name, _ in self.roles]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise BindingError(f"role declared twice: {', '.join(duplicates)}")
        for name, kind in self.roles:
            if kind not in KIND_PARENTS:
                raise BindingError(f"role `{name}` has unknown kind `{kind}`; kinds are "
                                   f"{', '.join(KIND_PARENTS)}")
        for rel, args in self.requires:
            if rel not in self.impls:
                raise BindingError(f"`{rel}` is not a relation")
            builtin = BUILTINS.get(rel)
            if builtin is not None and rel not in self.custom and len(builtin.params) != len(args):
                raise BindingError(f"{rel}({', '.join(args)}) takes {len(builtin.params)} "
                                   f"argument(s): {builtin.signature}")
            unknown = [a for a in args if a not in names]
            if unknown:
                raise BindingError(f"{rel}({', '.join(args)}) names unknown role(s): "
                                   f"{', '.join(unknown)}")
        scene = {e.name: e for e in self.entities}
        kinds = dict(self.roles)
        for role, entity in self.fixed.items():
            if role not in kinds:
                raise BindingError(f"--bind {role}={entity}: no role `{role}`; roles are "
                                   f"{', '.join(names)}")
            if entity not in scene:
                raise BindingError(f"--bind {role}={entity}: the scene has no entity `{entity}`; "
                                   f"entities are {', '.join(scene)}")
            if not is_subkind(scene[entity].kind, kinds[role]):
                raise BindingError(f"--bind {role}={entity}: `{entity}` is of kind "
                                   f"{scene[entity].kind}, role `{role}` needs {kinds[role]}")

    def _candidates(self, role: str, kind: str) -> list[int]:
        pinned = self.fixed.get(role)
        return [e.index for e in self.entities
                if is_subkind(e.kind, kind) and (pinned is None or e.name == pinned)]

    def holds(self, relation: str, indices: tuple[int, ...]) -> bool:
        key = (relation, indices)
        if key not in self._memo:
            value = self.impls[relation](self.frames, *indices)
            self._memo[key] = bool(np.all(value))
        return self._memo[key]

    def search(self, *, check: bool = True) -> Iterator[tuple[int, ...]]:
        """Yield complete assignments (entity index per role, in role order), lexicographically.

        With check=False the relations are ignored (only kinds and injectivity count).
        """
        chosen: list[int] = []

        def extend(depth: int) -> Iterator[tuple[int, ...]]:
            if depth == len(self.roles):
                yield tuple(chosen)
                return
            for entity in self.candidates[self.roles[depth][0]]:
                if entity in chosen:
                    continue
                chosen.append(entity)
                if not check or all(self.holds(rel, self._args(args, chosen))
                                    for rel, args in self.due[depth]):
                    yield from extend(depth + 1)
                chosen.pop()

        yield from extend(0)

    def _args(self, args: tuple[str, ...], chosen: list[int]) -> tuple[int, ...]:
        return tuple(chosen[self.position[a]] for a in args)

    def tuples(self, args: tuple[str, ...]) -> Iterator[tuple[int, ...]]:
        """Candidate entity tuples for one relation's roles (distinct roles, distinct entities)."""
        distinct = list(dict.fromkeys(args))
        for combo in product(*(self.candidates[a] for a in distinct)):
            if len(set(combo)) == len(combo):
                assigned = dict(zip(distinct, combo, strict=True))
                yield tuple(assigned[a] for a in args)

    def quote(self, args: tuple[str, ...], tuples: list[tuple[int, ...]]) -> str:
        """`(o=box, s=table), (o=cube, s=table) and 3 more`."""
        shown = []
        for indices in tuples[:_EXAMPLES]:
            pairs = dict(zip(args, indices, strict=True))
            shown.append("(" + ", ".join(f"{a}={self.entities[i].name}" for a, i in pairs.items())
                         + ")")
        more = f" and {len(tuples) - _EXAMPLES} more" if len(tuples) > _EXAMPLES else ""
        return ", ".join(shown) + more

    def named(self, choice: tuple[int, ...]) -> dict[str, str]:
        pairs = zip(self.roles, choice, strict=True)
        return {name: self.entities[i].name for (name, _), i in pairs}
