"""The runtime half of a run session: load the compiled program, build a world, choose the
binding, execute. `rapidc run`, `rapidc verify` and the benchmarks all go through it.

The front end (rapid_dsl/api/compilation.py) checks and compiles a program into a `CompiledProgram`
(runtime/compiled.py): the generated module's text and the entry to run, plain data that pickles
to worker processes and cluster workers. A `Session` loads it once (the loader verifies the
module before it runs: the trust boundary is the same wherever it is loaded) and then runs it on
any number of worlds. Nothing here imports the front end.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rapid_dsl.runtime.compiled import CompiledProgram
from rapid_dsl.runtime.config import Event, RunConfig
from rapid_dsl.runtime.entry_ranking import RequirementError, rank_entry
from rapid_dsl.runtime.executor import Executor
from rapid_dsl.runtime.loader import LoadedProgram, load
from rapid_dsl.runtime.program import Program
from rapid_dsl.runtime.ranking import Ranking
from rapid_dsl.runtime.results import RunResult
from rapid_dsl.runtime.scenes.scene import Scene
from rapid_dsl.runtime.scenes.world import World, build_world

__all__ = ["AmbiguousBinding", "Choice", "CompiledProgram", "Session", "choose_binding"]


class AmbiguousBinding(Exception):
    """Several bindings tie at the top score and nothing says which to take."""

    def __init__(self, entry: str, ranking: Ranking) -> None:
        self.entry = entry
        self.ranking = ranking
        top = ranking.candidates[0]
        super().__init__(f"the binding of `{entry}` is ambiguous: {ties(ranking)} bindings tie "
                         f"at score {top.score:g}")


@dataclass(frozen=True, slots=True)
class Choice:
    """The pins that select the binding to run, and how it was chosen (None: nothing to say)."""

    pins: dict[str, str]
    note: str | None


def ties(ranking: Ranking) -> int:
    """How many bindings share the top score."""
    return sum(c.score == ranking.candidates[0].score for c in ranking.candidates)


def binding_text(binding: Mapping[str, str]) -> str:
    return ", ".join(f"{role}={entity}" for role, entity in binding.items())


def choose_binding(program: Program, world: World, entry: str, pins: Mapping[str, str],
                   hints: Mapping[str, str], *, best: bool) -> Choice:
    """The ranked binding to run (docs/binding.md): the top one, unless it ties and not `best`.

    Raises BindingError for bad pins or hints or a search past its budget, and AmbiguousBinding.
    No binding, or a clause that fails to evaluate, leaves the pins as given: the run reports it
    as a failure.
    """
    try:
        ranking = rank_entry(program, world, entry, pins=pins, hints=hints, explain=False)
    except RequirementError:
        return Choice(dict(pins), None)
    if not ranking.candidates:
        return Choice(dict(pins), None)
    top = ranking.candidates[0]
    if ranking.ambiguous and not best:
        raise AmbiguousBinding(entry, ranking)
    note = None
    if ranking.ambiguous:
        note = (f"--best: {ranking.count}, the top ones tie at score {top.score:g}; took the "
                f"top-ranked ({binding_text(top.binding)})")
    elif len(ranking.candidates) > 1:
        note = (f"{ranking.count}; the top-ranked ({binding_text(top.binding)}) scores "
                f"{top.score:g}, the next {ranking.candidates[1].score:g} (rapidc bind lists them)")
    return Choice(dict(top.binding), note)


class Session:
    """One compiled program, loaded once, run on worlds. Raises LoadError when the loader
    refuses the generated module (nothing of it ran)."""

    def __init__(self, compiled: CompiledProgram) -> None:
        self.compiled = compiled
        self.loaded: LoadedProgram = load(compiled.source, compiled.name)

    @property
    def program(self) -> Program:
        return self.loaded.program

    @property
    def entry(self) -> str:
        return self.compiled.entry

    def world(self, scene: Scene) -> World:
        return build_world(scene)

    def executor(self, world: World, config: RunConfig,
                 on_event: Callable[[Event], None] | None = None) -> Executor:
        return Executor(self.program, world, config=config, on_event=on_event,
                        locate=self.loaded.locate)

    def execute(self, executor: Executor, *, pins: Mapping[str, str] | None = None,
                arguments: Mapping[str, Any] | None = None, scene: str = "") -> RunResult:
        """Run the entry. Raises BindingError and ArgumentError (bad input), as Executor.run."""
        # A program's arithmetic may overflow (a keypoint 1e300 m away): the executor reports
        # non-finite costs and points as failures; numpy's warnings would only name its files.
        with np.errstate(all="ignore"):
            return executor.run(self.entry, pins=pins, arguments=arguments, scene=scene)

    def choose(self, world: World, pins: Mapping[str, str], hints: Mapping[str, str], *,
               best: bool) -> Choice:
        return choose_binding(self.program, world, self.entry, pins, hints, best=best)
