"""Before anything moves: bind an entry's roles, evaluate its lets and judge its filters.

`screen(program, world, entry)` is what a run does first and what verification calls per scene
variant without running anything else. Filters are the `filter` blocks of the entry and, for a
strategy, of every phase's primitive (over the phase's role map), all judged in the start state;
a phase's primitive filter sees its param defaults and the phase's arguments as evaluated in the
start state (a filter that cannot be evaluated because an argument needs a later state, such as a
`solve` over the state a previous phase leaves, is left out). A false filter clause rejects the
start state: `rejected` is an outcome of its own, neither success nor failure, and nothing runs.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from rapid_dsl.runtime.binding import BindingError, Problem
from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.judging import Evaluator, Locate, PhaseError, filter_rejection
from rapid_dsl.runtime.params import given_values, plain_param
from rapid_dsl.runtime.program import Context, Primitive, Program, Strategy
from rapid_dsl.runtime.results import ClauseResult
from rapid_dsl.runtime.scenes.world import World
from rapid_dsl.runtime.state import RunState

BINDING_LIMIT = 64           # bindings enumerated to report ambiguity


@dataclass(slots=True)
class Screening:
    """The start state as an entry sees it, before any motion."""

    binding: dict[str, str] = field(default_factory=dict)       # role -> entity name
    binding_note: str | None = None                             # other bindings, in words
    roles: dict[str, int] = field(default_factory=dict)         # role -> entity index
    lets: dict[str, Any] = field(default_factory=dict)
    filters: dict[str, list[ClauseResult]] = field(default_factory=dict)  # declaration/phase
    failure: str | None = None       # no binding, or an error evaluating lets or filters
    rejection: str | None = None     # the first false filter clause, with its value

    @property
    def rejected(self) -> bool:
        return self.rejection is not None


def screen(program: Program, world: World, entry: str, *, pins: Mapping[str, str] | None = None,
           arguments: Mapping[str, Any] | None = None, locate: Locate | None = None,
           state: RunState | None = None) -> Screening:
    """Bind `entry`'s roles in the world's start state (or `state`), evaluate its lets, judge
    its filters. Raises KeyError for an unknown entry and BindingError for malformed pins (and
    BindingBudgetError for a search past its budget)."""
    decl = program.declaration(entry)
    evaluator = Evaluator(locate)
    if state is None:
        with RunState(world, nthread=1) as fresh:
            return _screen(program, decl, fresh.frames(), pins or {}, arguments or {}, evaluator)
    return _screen(program, decl, state.frames(), pins or {}, arguments or {}, evaluator)


def _screen(program: Program, decl: Primitive | Strategy, frames: Frames,
            pins: Mapping[str, str], arguments: Mapping[str, Any],
            evaluator: Evaluator) -> Screening:
    result = Screening()
    try:
        if not _bind(decl, frames, pins, evaluator, result):
            return result
        if isinstance(decl, Primitive):
            values = given_values(decl, Context(frames, result.roles), arguments, evaluator)
            _filter(decl, decl.name, frames, result.roles, values, evaluator, result)
        else:
            _strategy_filters(program, decl, frames, evaluator, result)
    except PhaseError as exc:
        result.failure = str(exc)
        return result
    for where, clauses in result.filters.items():
        false = next((c for c in clauses if not c.holds), None)
        if false is not None:
            owner = f"`{where}`" if where == decl.name else f"phase `{where}`"
            if where != decl.name and isinstance(decl, Strategy):
                used = next(p.primitive for p in decl.phases if p.name == where)
                owner += f" ({used})"
            result.rejection = filter_rejection(owner, false)
            break
    return result


def _strategy_filters(program: Program, strategy: Strategy, frames: Frames,
                      evaluator: Evaluator, result: Screening) -> None:
    """The strategy's lets and filter, then each phase's primitive filter over its role map."""
    if strategy.lets is not None:
        result.lets = evaluator.call(strategy.lets, Context(frames, result.roles), "let")
    context = Context(frames, result.roles, lets=result.lets)
    result.filters[strategy.name] = evaluator.judge(strategy.filter, context, "filter")
    for phase in strategy.phases:
        primitive = program.primitive(phase.primitive)
        mapped = {p: result.roles[s] for p, s in phase.role_map}
        given: dict[str, Any] = {}
        if phase.arguments is not None:
            try:
                given = evaluator.call(phase.arguments, context,
                                       f"arguments of phase `{phase.name}`")
            except PhaseError:
                given = {}   # e.g. a solve that needs the previous phase's state
        values = given_values(primitive, Context(frames, mapped), given, evaluator)
        _filter(primitive, phase.name, frames, mapped, values, evaluator, result)


def _filter(primitive: Primitive, where: str, frames: Frames, roles: dict[str, int],
            values: Mapping[str, Any], evaluator: Evaluator, result: Screening) -> None:
    """Judge `primitive`'s filter in the start state under `roles` and the given param values."""
    if not primitive.filter.clauses:
        result.filters[where] = []
        return
    params = {p.name: plain_param(p, values[p.name]) for p in primitive.params if p.name in values}
    try:
        features = evaluator.call(primitive.features, Context(frames, roles, params), "resolve")
        result.filters[where] = evaluator.judge(primitive.filter,
                                                Context(frames, roles, params, features), "filter")
    except PhaseError:
        if len(params) == len(primitive.params):
            raise
        # a param whose argument needs a later state: judged when verification can, not here


def _bind(decl: Primitive | Strategy, frames: Frames, pins: Mapping[str, str],
          evaluator: Evaluator, result: Screening) -> bool:
    roles = [(r.name, r.kind) for r in decl.roles]
    names = [f"requires[{i}] {req.text}" for i, req in enumerate(decl.requires)]
    requires = [(name, req.roles) for name, req in zip(names, decl.requires, strict=True)]
    relations = {name: evaluator.guarded(req.test, f"requires `{req.text}`")
                 for name, req in zip(names, decl.requires, strict=True)}
    problem = Problem(roles, requires, frames, pins, relations)
    found = [problem.named(s.choice) for s in problem.ranked()[0][:BINDING_LIMIT]]
    if not found:
        reason = problem.explain()
        for name, req in zip(names, decl.requires, strict=True):
            reason = reason.replace(f"{name}({', '.join(req.roles)})", req.text)
        result.failure = reason
        return False
    result.binding = dict(found[0])
    if len(found) > 1:
        count = f"at least {len(found)}" if len(found) == BINDING_LIMIT else str(len(found))
        others = "; ".join(binding_text(b) for b in found[1:4])
        result.binding_note = (f"{count} bindings satisfy the roles and requires; using the "
                               f"first ({binding_text(found[0])}). Others: {others}. Pin "
                               "roles with --bind role=entity.")
    table = frames.entities
    result.roles = {role: table.index(entity) for role, entity in found[0].items()}
    return True


def binding_text(binding: Mapping[str, str]) -> str:
    return ", ".join(f"{role}={entity}" for role, entity in binding.items())


__all__ = ["BindingError", "Screening", "screen"]
