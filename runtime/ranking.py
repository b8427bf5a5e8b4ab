"""Ranked bindings, whether the best one is unambiguous, and why expected entities were rejected.

What `rapidc bind` prints and `rapidc run` decides with (docs/binding.md). `rank` enumerates
Bind_E(roles, requires) with binding.Problem (best first: name/label score, then fewest
alternatives, then entity order). The best binding is *unambiguous* when it is the only one or
its score is strictly higher than the second's; ties on score alone are ambiguous, whatever the
alternatives say.

A rejection says why an entity a user would expect for a role is in no binding for it:
- an entity of a kind that cannot fill the role (the floor for a Fixture role, an Object for a
  Surface role, ...) is reported only when its name or label matches the role or its hint;
- an entity that can fill it is reported with the first requirement naming the role that is false
  for every choice of the other roles, with the relation's value (`touching(box, wall) is false
  (distance 0.31 m)`); failing that, with the first requirement that is false when the entity
  takes the role's place in the best binding it fits in.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rapid_dsl.language.kinds import fills
from rapid_dsl.runtime.binding import (
    Problem,
    RelationImpl,
    Requirement,
    Role,
    Scored,
    kind_mismatch,
)
from rapid_dsl.runtime.evidence import evidence, parse_call
from rapid_dsl.runtime.frames import Frames

_TUPLES = 1000   # candidate tuples tried per requirement when explaining a rejection


@dataclass(frozen=True, slots=True)
class Candidate:
    """One binding with its rank keys."""

    binding: dict[str, str]       # role -> entity name, in role order
    score: float                  # sum of `scores`
    scores: dict[str, float]      # role -> similarity score of its entity
    alternatives: int             # bindings that differ from it in exactly one role


@dataclass(frozen=True, slots=True)
class Rejection:
    """Why `entity` fills `role` in no binding."""

    role: str
    entity: str
    reason: str                   # `touching(box, wall) is false (distance 0.31 m)`
    requirement: str | None       # the false requirement's text; None for a kind mismatch
    value: str | None             # the relation's value, when it is a builtin relation

    @property
    def text(self) -> str:
        return f"{self.role}={self.entity}: {self.reason}"


@dataclass(frozen=True, slots=True)
class Ranking:
    roles: tuple[Role, ...]
    candidates: tuple[Candidate, ...]    # every binding found, best first
    complete: bool                       # False: the search stopped at ENUMERATION_CAP
    rejections: tuple[Rejection, ...]
    reason: str | None                   # why nothing binds (None when something does)

    @property
    def ambiguous(self) -> bool:
        first, *rest = self.candidates or (None,)
        return first is not None and bool(rest) and not first.score > rest[0].score

    @property
    def best(self) -> Candidate | None:
        """The top-ranked binding when it is unambiguous."""
        return self.candidates[0] if self.candidates and not self.ambiguous else None

    @property
    def count(self) -> str:
        """`1 binding`, `3 bindings`, `more than 10000 bindings`."""
        n = len(self.candidates)
        if not self.complete:
            return f"more than {n} bindings"
        return f"{n} binding" if n == 1 else f"{n} bindings"

    def status(self) -> str:
        """`unique`, `best` (several, the top strictly better), `ambiguous` or `none`."""
        if not self.candidates:
            return "none"
        if self.ambiguous:
            return "ambiguous"
        return "unique" if len(self.candidates) == 1 else "best"

    def to_json(self, limit: int | None = None) -> dict[str, Any]:
        """The stable JSON shape of `rapidc bind --format json` (docs/binding.md)."""
        shown = self.candidates[:limit]
        return {
            "status": self.status(),
            "roles": [{"name": name, "kind": kind} for name, kind in self.roles],
            "total": len(self.candidates), "complete": self.complete, "shown": len(shown),
            "bindings": [{"rank": i + 1, "binding": c.binding, "score": c.score,
                          "scores": c.scores, "alternatives": c.alternatives}
                         for i, c in enumerate(shown)],
            "rejected": [{"role": r.role, "entity": r.entity, "reason": r.reason,
                          "requirement": r.requirement, "value": r.value}
                         for r in self.rejections],
            "reason": self.reason,
        }


def rank(
    roles: Sequence[Role],
    requires: Sequence[Requirement],
    frames: Frames,
    *,
    fixed: Mapping[str, str] | None = None,
    relations: Mapping[str, RelationImpl] | None = None,
    hints: Mapping[str, str] | None = None,
    texts: Mapping[str, str] | None = None,
    explain: bool = True,
) -> Ranking:
    """Rank Bind_E(roles, requires) in `frames` and explain the rejected entities.

    Arguments as for binding.bind; `texts` names how a custom relation is shown (a compiled
    `requires` clause: its source text); without `explain` there are no rejections and no
    reason. Raises BindingError for malformed input and BindingBudgetError when the search and
    its explanation together take more than MAX_BINDING_STEPS steps.
    """
    problem = Problem(roles, requires, frames, fixed or {}, relations or {}, hints or {})
    scored, complete = problem.ranked()
    explainer = _Explainer(problem, scored, complete, texts or {})
    reason = None
    if explain and not scored:
        reason = problem.explain()
        for relation, args in problem.requires:
            shown = explainer.show(relation, args)
            reason = reason.replace(f"{relation}({', '.join(args)})", shown)
    return Ranking(
        roles=tuple(problem.roles),
        candidates=tuple(_candidate(problem, s) for s in scored),
        complete=complete,
        rejections=tuple(explainer.rejections()) if explain else (),
        reason=reason,
    )


def _candidate(problem: Problem, scored: Scored) -> Candidate:
    pairs = list(zip(problem.roles, scored.choice, strict=True))
    return Candidate(problem.named(scored.choice), scored.score,
                     {name: problem.scores[name, e] for (name, _), e in pairs},
                     scored.alternatives)


class _Explainer:
    def __init__(self, problem: Problem, scored: list[Scored], complete: bool,
                 texts: Mapping[str, str]) -> None:
        self.problem = problem
        self.scored = scored
        self.complete = complete
        self.texts = texts
        self.names = [e.name for e in problem.entities]
        self._support: dict[str, set[int]] = {}

    def show(self, relation: str, args: tuple[str, ...]) -> str:
        return self.texts.get(relation) or f"{relation}({', '.join(args)})"

    def rejections(self) -> list[Rejection]:
        found = []
        problem = self.problem
        for position, (role, kind) in enumerate(problem.roles):
            if role in problem.fixed:
                continue
            used = {s.choice[position] for s in self.scored}
            for entity in problem.entities:
                if not fills(entity.kind, entity.shape, kind):
                    if problem.scores[role, entity.index] > 0:
                        found.append(Rejection(role, entity.name,
                                               kind_mismatch(entity, role, kind), None, None))
                elif entity.index not in used:
                    rejection = self._rejection(position, entity.index)
                    if rejection is not None:
                        found.append(rejection)
        return found

    def _rejection(self, position: int, entity: int) -> Rejection | None:
        problem = self.problem
        role = problem.roles[position][0]
        top = self.scored[0].choice if self.scored else None
        # A requirement false for every choice of the other roles rules the entity out alone.
        for relation, args in problem.requires:
            if role not in args:
                continue
            tuples = problem.explained_tuples(args, {role: entity}, _TUPLES)
            if not tuples or any(problem.holds(relation, t) for t in tuples):
                continue
            preferred = [t for t in tuples if top is not None and all(
                e == top[problem.position[a]] for a, e in zip(args, t, strict=True) if a != role)]
            others = sorted({a for a in args if a != role})
            every = f" for every choice of {', '.join(others)}" if len(tuples) > 1 else ""
            return self._false(role, entity, relation, args, (preferred or tuples)[0], every)
        name = self.names[entity]
        for other, _ in problem.roles:
            if other != role and self._possible(other) == {entity}:
                return Rejection(role, name, f"`{name}` is the only entity role `{other}` can "
                                 "take", None, None)
        if not self.complete:
            return None   # it may be in a binding the search did not reach
        if not self.scored:
            return None   # no binding at all: Ranking.reason says why
        for candidate in self.scored:
            if entity in candidate.choice:
                continue
            trial = list(candidate.choice)
            trial[position] = entity
            for relation, args in problem.requires:
                indices = tuple(trial[problem.position[a]] for a in args)
                if role in args and not problem.holds(relation, indices):
                    with_ = ", ".join(f"{a}={self.names[trial[problem.position[a]]]}"
                                      for a in dict.fromkeys(args) if a != role)
                    return self._false(role, entity, relation, args, indices,
                                       f" with {with_}" if with_ else "")
        # Every binding it fits in already uses it for another role.
        taken = next(problem.roles[i][0] for i, e in enumerate(self.scored[0].choice)
                     if e == entity)
        return Rejection(role, name, f"`{name}` fills role `{taken}` in every binding", None,
                         None)

    def _possible(self, role: str) -> set[int]:
        """The candidates of `role` for which each requirement naming it holds for some choice
        of the other roles (all of them when there are too many choices to try)."""
        if role not in self._support:
            problem = self.problem
            self._support[role] = {
                c for c in problem.candidates[role]
                if all(self._can_hold(relation, args, role, c)
                       for relation, args in problem.requires if role in args)}
        return self._support[role]

    def _can_hold(self, relation: str, args: tuple[str, ...], role: str, entity: int) -> bool:
        tuples = self.problem.explained_tuples(args, {role: entity}, _TUPLES)
        return tuples is None or any(self.problem.holds(relation, t) for t in tuples)

    def _false(self, role: str, entity: int, relation: str, args: tuple[str, ...],
               indices: tuple[int, ...], context: str) -> Rejection:
        shown = self.show(relation, args)
        value = self._value(relation, args, indices)
        reason = f"{shown} is false{context}" + (f" ({value})" if value else "")
        return Rejection(role, self.names[entity], reason, shown, value)

    def _value(self, relation: str, args: tuple[str, ...], indices: tuple[int, ...]) -> str | None:
        """The builtin relation's numbers; a compiled clause that is one call gets them too."""
        frames = self.problem.frames
        if relation not in self.problem.custom:
            return evidence(frames, relation, indices)
        call = parse_call(self.show(relation, args))
        if call is None or not set(call[1]) <= set(args):
            return None
        by_role = dict(zip(args, indices, strict=True))
        return evidence(frames, call[0], tuple(by_role[a] for a in call[1]))
