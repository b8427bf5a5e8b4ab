"""Binding: type-compatible, injective assignments of scene entities to roles that satisfy Gamma.

Bind_E(r, Gamma) of the paper. Candidates for a role are the entities that may fill its kind
(`kinds.fills`: a subkind, and never the floor for a Fixture role), best name/label match first
(`similarity.role_score`); roles are filled in declaration order by backtracking, and a relation
is checked as all its roles are filled. Relations are evaluated on `frames` (normally B=1,
T=1: the current state) and must hold at every recorded sample and time point.

Bindings are ranked (docs/binding.md): highest total score first, then fewest alternatives (other
bindings that differ from it in exactly one role), then entity order. Ranking needs them all, so
the search stops after `ENUMERATION_CAP` and says so.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from itertools import islice, product

import numpy as np

from rapid_dsl.language.kinds import FACELESS_SHAPES, KIND_PARENTS, fills, is_subkind
from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.runtime.builtins import IMPLEMENTATIONS
from rapid_dsl.runtime.frames import Entity, Frames
from rapid_dsl.runtime.similarity import role_score

Role = tuple[str, str]                      # (role name, kind)
Requirement = tuple[str, tuple[str, ...]]   # (relation name, role names)
RelationImpl = Callable[..., np.ndarray]

_EXAMPLES = 4  # candidate tuples quoted per relation in explanations
ENUMERATION_CAP = 10_000  # bindings enumerated for ranking; more are counted as "more than"


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
    hints: Mapping[str, str] | None = None,
) -> list[dict[str, str]]:
    """Every binding {role: entity name} of the scene in `frames`, ranked (best first).

    `fixed` pins roles to entity names (from `--bind role=name`); `relations` adds implementations
    (e.g. compiled derived relations) to the builtin ones, called as `impl(frames, *indices)`;
    `hints` gives roles words to match entity names and labels against (`--hint role=text`);
    `limit` keeps that many. Raises BindingError for malformed input.
    """
    problem = Problem(roles, requires, frames, fixed or {}, relations or {}, hints or {})
    ranked, _ = problem.ranked()
    return [problem.named(r.choice) for r in ranked[:limit]]


def explain_no_binding(
    roles: Sequence[Role],
    requires: Sequence[Requirement],
    frames: Frames,
    *,
    fixed: Mapping[str, str] | None = None,
    relations: Mapping[str, RelationImpl] | None = None,
) -> str:
    """A readable reason why `bind` finds nothing: missing kinds, or which relation failed."""
    problem = Problem(roles, requires, frames, fixed or {}, relations or {})
    lines = [f"role `{name}: {kind}` has no candidate (the scene has no entity of kind {kind}"
             + ("; the floor is a Surface only)" if kind == "Fixture" else ")")
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


@dataclass(frozen=True, slots=True)
class Scored:
    """One binding as entity indices in role order, with its rank keys."""

    choice: tuple[int, ...]
    score: float            # sum over roles of role_score
    alternatives: int       # bindings that differ from this one in exactly one role


def kind_mismatch(entity: Entity, role: str, kind: str) -> str:
    """Why `entity` cannot fill `role: kind`, in words."""
    if kind == "Fixture" and entity.shape in FACELESS_SHAPES and is_subkind(entity.kind, kind):
        return (f"`{entity.name}` is a plane (the floor): a Surface only, with no side face for "
                f"Fixture role `{role}`")
    return f"`{entity.name}` is of kind {entity.kind}, role `{role}` needs {kind}"


class Problem:
    """Validated roles, scored candidates and a memo of relation values."""

    def __init__(
        self,
        roles: Sequence[Role],
        requires: Sequence[Requirement],
        frames: Frames,
        fixed: Mapping[str, str],
        relations: Mapping[str, RelationImpl],
        hints: Mapping[str, str] | None = None,
    ) -> None:
        self.frames = frames
        self.entities = frames.entities.entities
        self.roles = [(str(name), str(kind)) for name, kind in roles]
        self.requires = [(str(rel), tuple(args)) for rel, args in requires]
        self.fixed = dict(fixed)
        self.hints = dict(hints or {})
        builtin = {n: IMPLEMENTATIONS[n] for n, b in BUILTINS.items() if b.kind == "relation"}
        self.impls = {**builtin, **relations}
        self.custom = set(relations)
        self.position = {name: i for i, (name, _) in enumerate(self.roles)}
        self._memo: dict[tuple[str, tuple[int, ...]], bool] = {}
        self._validate()
        self.scores = {(name, e.index): role_score(name, self.hints.get(name), e.name, e.label)
                       for name, _ in self.roles for e in self.entities}
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
        for role in self.hints:
            if role not in kinds:
                raise BindingError(f"--hint {role}=...: no role `{role}`; roles are "
                                   f"{', '.join(names)}")
        for role, entity in self.fixed.items():
            if role not in kinds:
                raise BindingError(f"--bind {role}={entity}: no role `{role}`; roles are "
                                   f"{', '.join(names)}")
            if entity not in scene:
                raise BindingError(f"--bind {role}={entity}: the scene has no entity `{entity}`; "
                                   f"entities are {', '.join(scene)}")
            if not fills(scene[entity].kind, scene[entity].shape, kinds[role]):
                why = kind_mismatch(scene[entity], role, kinds[role])
                raise BindingError(f"--bind {role}={entity}: {why}")

    def _candidates(self, role: str, kind: str) -> list[int]:
        pinned = self.fixed.get(role)
        found = [e.index for e in self.entities
                 if fills(e.kind, e.shape, kind) and (pinned is None or e.name == pinned)]
        return sorted(found, key=lambda e: -self.scores[role, e])

    def score(self, choice: tuple[int, ...]) -> float:
        return round(sum(self.scores[name, e] for (name, _), e in zip(self.roles, choice,
                                                                      strict=True)), 3)

    def ranked(self) -> tuple[list[Scored], bool]:
        """Bindings found (at most ENUMERATION_CAP), best first; and whether that is all of them."""
        found = list(islice(self.search(), ENUMERATION_CAP + 1))
        complete = len(found) <= ENUMERATION_CAP
        found = found[:ENUMERATION_CAP]
        known = set(found)
        scored = []
        for choice in found:
            alternatives = 0
            for position, (name, _) in enumerate(self.roles):
                for other in self.candidates[name]:
                    if other != choice[position]:
                        swapped = choice[:position] + (other,) + choice[position + 1:]
                        alternatives += swapped in known
            scored.append(Scored(choice, self.score(choice), alternatives))
        scored.sort(key=lambda s: (-s.score, s.alternatives, s.choice))
        return scored, complete

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

    def tuples(self, args: tuple[str, ...], given: Mapping[str, int] | None = None,
               ) -> Iterator[tuple[int, ...]]:
        """Candidate entity tuples for one relation's roles (distinct roles, distinct entities);
        `given` fixes some roles' entities."""
        distinct = list(dict.fromkeys(args))
        given = given or {}
        pools = [[given[a]] if a in given else self.candidates[a] for a in distinct]
        for combo in product(*pools):
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
