"""Run a compiled program on a MuJoCo world: screening, Exec(P) by CEM, strategies phase by phase.

A run first screens its start state (runtime/screening.py: bind the roles, evaluate the lets,
judge the filters; a false filter clause rejects the state and nothing runs), then judges the
entry's success clauses in that state (a clause already true is a vacuity warning), then executes.
A primitive entry is one phase; a strategy runs its phases in order (runtime/phases.py: each
phase's arguments are evaluated just in time, in the state the previous phase left) and stops at
its first failed phase (tried again first, up to its `retry` count), unless that phase says
`on_fail continue`. Problems of the program or the scene become reported failures in the
`RunResult`, never exceptions.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any, Literal

import numpy as np

from rapid_dsl.runtime import memory
from rapid_dsl.runtime.binding import BindingError
from rapid_dsl.runtime.config import UNSTABLE_COST, Event, RunConfig
from rapid_dsl.runtime.judging import (
    Evaluator,
    Locate,
    PhaseError,
    clause_failure,
    vacuity,
    with_start,
)
from rapid_dsl.runtime.motion import Timing
from rapid_dsl.runtime.params import ArgumentError, check_arguments
from rapid_dsl.runtime.phases import PhaseCall, PhaseRunner, planning_steps
from rapid_dsl.runtime.program import Context, Phase, Primitive, Program, Strategy
from rapid_dsl.runtime.results import PhaseResult, RunResult
from rapid_dsl.runtime.scenes.world import World
from rapid_dsl.runtime.screening import Screening, screen
from rapid_dsl.runtime.simulate import Simulator
from rapid_dsl.runtime.state import RunState


class Executor:
    """Runs declarations of one compiled program on one world."""

    def __init__(self, program: Program, world: World, *, config: RunConfig | None = None,
                 on_event: Callable[[Event], None] | None = None,
                 locate: Locate | None = None) -> None:
        self.program = program
        self.world = world
        self.config = config or RunConfig()
        self.on_event = on_event or (lambda event: None)
        self.evaluator = Evaluator(locate)
        self.planning_dt = self.config.planning_dt or world.dt
        self.planning_steps = planning_steps(_timing(self.config, world), self.planning_dt)
        self.motions: list[tuple[np.ndarray, np.ndarray]] = []   # (state0, ctrl) per execution

    # ---------------------------------------------------------------------------- entry points

    def run(self, entry: str, *, pins: Mapping[str, str] | None = None,
            arguments: Mapping[str, Any] | None = None, scene: str = "") -> RunResult:
        """Screen `entry`'s start state and, unless rejected, execute it.

        Raises BindingError for malformed pins, ArgumentError for arguments that do not fit a
        primitive entry's params and MemoryBudgetError for a run whose estimated memory is above
        the limit (all bad input, found before anything is simulated); everything else is
        reported in the result.
        """
        decl = self._declaration(entry)
        memory.check(self.program, self.world, entry, self.config)
        kind: Literal["primitive", "strategy"] = "strategy" if isinstance(decl, Strategy) \
            else "primitive"
        result = RunResult(self.program.path, entry, kind, scene, self._seed(decl))
        if isinstance(decl, Primitive):
            check_arguments(decl, arguments or {})
        elif arguments:
            raise ArgumentError(f"`{entry}` is a strategy: it takes no --arg (its phases compute "
                                "their own arguments)")
        started = time.perf_counter()
        with RunState(self.world, nthread=self.config.nthread,
                      planning_dt=self.planning_dt) as state:
            self.motions = state.motions
            screened = screen(self.program, self.world, entry, pins=pins, arguments=arguments,
                              locate=self.evaluator.locate, state=state)
            self._report_screening(screened, result)
            if screened.failure is None and not screened.rejected:
                runner = PhaseRunner(state, self.config, self.evaluator, on_event=self.on_event,
                                     seed=self._seed)
                if isinstance(decl, Primitive):
                    self._run_primitive(decl, screened, dict(arguments or {}), runner, result)
                else:
                    self._run_strategy(decl, screened, runner, state, result)
                result.warnings += runner.warnings
            result.final_poses = state.poses()
        result.seconds["total"] = time.perf_counter() - started
        return result

    def screen(self, entry: str, *, pins: Mapping[str, str] | None = None,
               arguments: Mapping[str, Any] | None = None) -> Screening:
        """Binding, lets and filters of `entry` in the world's start state; nothing runs."""
        self._declaration(entry)
        return screen(self.program, self.world, entry, pins=pins, arguments=arguments,
                      locate=self.evaluator.locate)

    def states(self, every: int) -> np.ndarray:
        """(T, nstate) states of every executed motion, one per `every` physics steps (video)."""
        with Simulator(self.world, nthread=1) as sim:
            if not self.motions:
                return sim.initial_state()[None]
            parts = [sim.trajectory(state0, ctrl, every=every) for state0, ctrl in self.motions]
        return np.concatenate(parts)

    # ------------------------------------------------------------------------------- running

    def _report_screening(self, screened: Screening, result: RunResult) -> None:
        result.binding, result.binding_note = screened.binding, screened.binding_note
        result.filters = screened.filters
        if screened.failure is not None:
            result.failure = screened.failure
        elif screened.rejected:
            result.rejected, result.failure = True, screened.rejection
        message = screened.failure if not screened.binding else \
            ", ".join(f"{r}={e}" for r, e in screened.binding.items())
        self.on_event(Event("binding", message=message or ""))

    def _run_primitive(self, primitive: Primitive, screened: Screening,
                       arguments: dict[str, Any], runner: PhaseRunner,
                       result: RunResult) -> None:
        phase = runner.execute(PhaseCall(primitive, primitive.name, primitive.origin,
                                         screened.roles, arguments, entry=True))
        result.phases.append(phase)
        result.success = phase.success
        result.succeeded = phase.succeeded
        if not phase.succeeded:
            result.failure = phase.failure

    def _run_strategy(self, strategy: Strategy, screened: Screening, runner: PhaseRunner,
                      state: RunState, result: RunResult) -> None:
        roles, lets = screened.roles, screened.lets
        try:
            start = self.evaluator.judge(strategy.success,
                                         Context(state.frames(), roles, lets=lets), "success")
        except PhaseError as exc:
            result.failure = str(exc)
            return
        result.warnings += vacuity(start, phase=None, where="the start state", each=True)
        stopped: PhaseResult | None = None
        for phase in strategy.phases:
            primitive = self.program.primitive(phase.primitive)
            if stopped is not None:
                names = {p: self.world.entities.entities[roles[s]].name
                         for p, s in phase.role_map}
                result.phases.append(PhaseResult(phase.name, primitive.name, phase.origin, names,
                                                 on_fail=phase.on_fail, retry=phase.retry))
                continue
            record = runner.execute(self._phase_call(phase, primitive, roles, lets, state))
            result.phases.append(record)
            if not record.succeeded and record.on_fail == "stop":
                stopped = record
        try:
            end = self.evaluator.judge(strategy.success,
                                       Context(state.frames(), roles, lets=lets), "success")
        except PhaseError as exc:
            result.failure = str(exc)
            return
        result.success = with_start(end, start)
        if stopped is not None:
            result.failure = f"phase `{stopped.name}`{_tries(stopped)}: {stopped.failure}"
            later = [p.name for p in result.phases if p.status == "not run"]
            if later:
                result.failure += f" (the strategy stopped there: {', '.join(later)} not run)"
            return
        if strategy.success.clauses:
            first = next((c for c in result.success if not c.holds), None)
            result.succeeded = first is None
            if first is not None:
                result.failure = clause_failure("strategy success", first)
        else:   # no success block: the strategy succeeds when every phase has
            failed = next((p for p in result.phases if not p.succeeded), None)
            result.succeeded = failed is None
            if failed is not None:
                result.failure = f"phase `{failed.name}`{_tries(failed)}: {failed.failure}"

    def _phase_call(self, phase: Phase, primitive: Primitive, roles: dict[str, int],
                    lets: Mapping[str, Any], state: RunState) -> PhaseCall:
        def arguments() -> dict[str, Any]:
            if phase.arguments is None:
                return {}
            return self.evaluator.call(phase.arguments, Context(state.frames(), roles, lets=lets),
                                       f"arguments of phase `{phase.name}`")
        return PhaseCall(primitive, phase.name, phase.origin,
                         {p: roles[s] for p, s in phase.role_map}, arguments,
                         phase.unchecked_requires, roles, phase.on_fail, retry=phase.retry)

    # ------------------------------------------------------------------------------- helpers

    def _declaration(self, entry: str) -> Primitive | Strategy:
        try:
            return self.program.declaration(entry)
        except KeyError:
            raise ArgumentError(f"the program declares no primitive or strategy `{entry}`") \
                from None

    def _seed(self, decl: Primitive | Strategy) -> int:
        if self.config.seed is not None:
            return self.config.seed
        if isinstance(decl, Primitive) and decl.optimize.seed is not None:
            return decl.optimize.seed
        return 0


def _tries(phase: PhaseResult) -> str:
    """` (3 attempts)` for a phase that was tried more than once, else nothing."""
    count = len(phase.attempts)
    return f" ({count} attempts)" if count > 1 else ""


def _timing(config: RunConfig, world: World) -> Timing:
    return Timing(dt=world.dt, control_steps=config.control_steps, settle=config.settle,
                  grip_dwell=config.grip_dwell)


MemoryBudgetError = memory.MemoryBudgetError

__all__ = ["ArgumentError", "BindingError", "Event", "Executor", "MemoryBudgetError", "RunConfig",
           "UNSTABLE_COST"]
