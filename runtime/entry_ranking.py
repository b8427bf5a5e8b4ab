"""Rank the bindings of one declaration of a compiled program in a world's start state.

The same problem the executor binds (its roles, its own `requires` as compiled relations, the
state before anything moves), ranked and explained by ranking.rank, for `rapidc bind` and for
`rapidc run` to choose from before it executes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.program import Program
from rapid_dsl.runtime.ranking import Ranking, rank
from rapid_dsl.runtime.scenes.world import World
from rapid_dsl.runtime.simulate import Simulator


class RequirementError(Exception):
    """A `requires` clause raised while it was evaluated (the message names its line)."""


def rank_entry(program: Program, world: World, entry: str, *,
               pins: Mapping[str, str] | None = None,
               hints: Mapping[str, str] | None = None, explain: bool = True) -> Ranking:
    """Ranking of `entry`'s roles in `world`'s start state (`explain`: with rejections and the
    reason when nothing binds, as ranking.rank).

    Raises KeyError for an unknown entry, BindingError for bad pins or hints (and
    BindingBudgetError for a search too large), RequirementError when a clause fails to evaluate.
    """
    decl = program.declaration(entry)
    names = [f"requires[{i}] {req.text}" for i, req in enumerate(decl.requires)]
    relations = {name: _guarded(req.test, f"requires `{req.text}` ({req.origin})")
                 for name, req in zip(names, decl.requires, strict=True)}
    return rank([(r.name, r.kind) for r in decl.roles],
                [(name, req.roles) for name, req in zip(names, decl.requires, strict=True)],
                start_frames(world), fixed=pins, relations=relations, hints=hints,
                texts={name: req.text for name, req in zip(names, decl.requires, strict=True)},
                explain=explain)


def start_frames(world: World) -> Frames:
    """The world's start state as Frames with B=1, T=1 (the hand holding still, open)."""
    with Simulator(world, nthread=1) as sim:
        data = world.make_data()
        state = sim.initial_state(data)
        sim.set_state(data, state)
        ctrl = world.robot.hold(world.robot.hand_pose(data), 0.0)
        return sim.rollout(state, ctrl[None, None], record_every=1).first()


def _guarded(test: Callable[..., Any], what: str) -> Callable[..., Any]:
    def call(*args: Any) -> Any:
        try:
            return test(*args)
        except Exception as exc:  # generated code raises many types
            raise RequirementError(f"evaluating {what} failed: {exc or type(exc).__name__}") \
                from None
    return call
