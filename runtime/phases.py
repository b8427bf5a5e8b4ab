"""Exec(P) for one phase: arguments, requirements, the start state's verdict, CEM, execution.

From the run's current state: evaluate the arguments (a strategy phase's just in time) over the
param defaults and range-check them, test the requirements the strategy does not state, judge the
success clauses in the start state (vacuity), evaluate the keypoints (the CEM mean), and optimize
by CEM over batched rollouts at the planning timestep. Plan = execute: the final CEM elites are run
again at the world's timestep and the best of those as executed (every success clause holding
first, then the lowest cost) is the phase's motion; its success is judged on that execution, and
the run continues from its final state. The record keeps the planned and the executed cost, the
success the plan promised, the chosen sample and keypoints, and the contacts, finger opening and
hand pose at the end.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rapid_dsl.language.limits import MIN_PLANNING_DT
from rapid_dsl.runtime.builtins import IMPLEMENTATIONS
from rapid_dsl.runtime.cem import CEMConfig, CEMResult, optimize
from rapid_dsl.runtime.config import UNSTABLE_COST, Event, RunConfig
from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.judging import Evaluator, PhaseError, clause_failure, vacuity, with_start
from rapid_dsl.runtime.motion import KeypointSet, Timing, hand_targets
from rapid_dsl.runtime.params import given_values, resolve_params
from rapid_dsl.runtime.program import Context, Primitive, Requirement
from rapid_dsl.runtime.results import (
    Attempt,
    ClauseResult,
    EndState,
    KeypointRecord,
    OnFail,
    PhaseResult,
    RunWarning,
    attempt_label,
)
from rapid_dsl.runtime.robots import HandPose
from rapid_dsl.runtime.simulate import Simulator, hold
from rapid_dsl.runtime.state import RunState

Arguments = Mapping[str, Any] | Callable[[], Mapping[str, Any]]
Controls = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True, slots=True)
class PhaseCall:
    """One execution of a primitive: a phase of a strategy, or the run's entry itself."""

    primitive: Primitive
    name: str
    origin: str
    roles: dict[str, int]                            # primitive role -> entity index
    arguments: Arguments                             # a function: evaluated at the phase's start
    checked: tuple[Requirement, ...] = ()            # requirements tested at the start ...
    checked_roles: Mapping[str, int] | None = None   # ... over these roles (a strategy's)
    on_fail: OnFail = "stop"
    entry: bool = False                              # its success is the run's own predicate
    retry: int = 0                                   # further attempts after a failed one


@dataclass(frozen=True, slots=True)
class _Plan:
    keypoints: KeypointSet
    controls: Controls
    state0: np.ndarray
    params: dict[str, Any]
    start_success: list[ClauseResult]


class PhaseRunner:
    """Runs phases on one run's state; collects the warnings they raise."""

    def __init__(self, run: RunState, config: RunConfig, evaluator: Evaluator, *,
                 on_event: Callable[[Event], None], seed: Callable[[Primitive], int]) -> None:
        self.run = run
        self.world = run.world
        self.config = config
        self.evaluator = evaluator
        self.on_event = on_event
        self.seed = seed
        self.timing = Timing(dt=self.world.dt, control_steps=config.control_steps,
                             settle=config.settle, grip_dwell=config.grip_dwell)
        self.planning_steps = planning_steps(self.timing, run.planner.dt)
        self.warnings: list[RunWarning] = []

    def cem_config(self, primitive: Primitive) -> CEMConfig:
        samples = self.config.samples or primitive.optimize.samples
        iterations = self.config.iterations or primitive.optimize.iterations
        elites = max(1, min(primitive.optimize.elites, samples // 2 or 1))
        return CEMConfig(samples=samples, elites=elites, iterations=iterations)

    def execute(self, call: PhaseCall) -> PhaseResult:
        """Exec(P) from the current state, tried again from the state reached while it fails, up
        to `call.retry` more times; leaves the state at the end of the last executed motion. The
        record is the last attempt's, with every attempt listed."""
        attempts: list[Attempt] = []
        while True:
            record = self._attempt(call, len(attempts) + 1)
            attempts.append(record.attempts[0])
            # an attempt that failed before moving left the state as it was: another would
            # evaluate the same arguments and requirements and fail the same way
            if record.succeeded or len(attempts) > call.retry or not attempts[-1].moved:
                break
        record.attempts = attempts
        return record

    def _attempt(self, call: PhaseCall, number: int) -> PhaseResult:
        config = self.cem_config(call.primitive)
        label = attempt_label(call.name, number)
        self.on_event(Event("phase", phase=label, message=call.primitive.name,
                            iterations=config.iterations))
        started = time.perf_counter()
        names = {r: self.world.entities.entities[i].name for r, i in call.roles.items()}
        record = PhaseResult(call.name, call.primitive.name, call.origin, names,
                             on_fail=call.on_fail, retry=call.retry)
        seed = self._attempt_seed(call.primitive, number)
        motions = len(self.run.motions)
        try:
            self._exec(call, config, record, seed, label)
        except PhaseError as exc:
            record.status, record.failure = "failed", str(exc)
        record.seconds["total"] = time.perf_counter() - started
        record.attempts = [Attempt(number, seed, record.status, record.failure,
                                   len(self.run.motions) > motions, dict(record.arguments),
                                   record.planned_cost, record.executed_cost,
                                   record.seconds["total"])]
        self.on_event(Event("phase_done", phase=label, message=record.status,
                            best_cost=_nan(record.planned_cost),
                            executed_cost=_nan(record.executed_cost)))
        return record

    def _attempt_seed(self, primitive: Primitive, number: int) -> list[int]:
        """The CEM seed of an attempt: the run's seed for the first (a phase without retries
        plans as it always has), [seed, number] for later ones, a fresh stream each."""
        seed = self.seed(primitive)
        return [seed] if number == 1 else [seed, number]

    # ------------------------------------------------------------------------------- steps

    def _exec(self, call: PhaseCall, config: CEMConfig, record: PhaseResult,
              seed: list[int], label: str) -> None:
        started = time.perf_counter()
        plan = self._prepare(call, record)
        record.seconds["init"] = time.perf_counter() - started
        solution = self._optimize(call, config, plan, record, seed, label)
        executing = time.perf_counter()
        self.on_event(Event("execute", phase=label, best_cost=solution.best_cost))
        self._execute(call, plan, solution, record)
        record.seconds["execute"] = time.perf_counter() - executing

    def _prepare(self, call: PhaseCall, record: PhaseResult) -> _Plan:
        """Arguments, requirements, the start state's verdict, keypoints; PhaseError if the phase
        cannot run."""
        primitive, roles = call.primitive, call.roles
        given = call.arguments() if callable(call.arguments) else call.arguments
        frames = self.run.frames()
        params = resolve_params(primitive, given_values(primitive, Context(frames, roles), given,
                                                        self.evaluator), record)
        self._requires(call.checked, call.checked_roles or roles, frames, record)
        start_success = self._success(primitive, frames, roles, params)
        self.warnings += vacuity(start_success, phase=None if call.entry else call.name,
                                 where="the start state" if call.entry else
                                 "the phase's start state", each=call.entry)
        features = self.evaluator.call(primitive.features, Context(frames, roles, params),
                                       "resolve")
        keypoints = KeypointSet.from_keypoints(self.evaluator.call(
            primitive.motion.keypoints, Context(frames, roles, params, features),
            "motion keypoints"))
        if not np.all(np.isfinite(keypoints.position)):
            bad = keypoints.names[int(np.flatnonzero(
                ~np.isfinite(keypoints.position).all(axis=1))[0])]
            raise PhaseError(f"keypoint `{bad}` is not a finite point in the start state")
        controls = self._controls(keypoints, primitive, self.run.hand())
        return _Plan(keypoints, controls, self.run.state.copy(), params, start_success)

    def _optimize(self, call: PhaseCall, config: CEMConfig, plan: _Plan,
                  record: PhaseResult, seed: list[int], label: str) -> CEMResult:
        primitive, planner = call.primitive, self.run.planner
        record.samples, record.iterations = config.samples, config.iterations
        evaluated = {"rollouts": 0, "steps": 0, "unstable": 0}

        def cost(population: np.ndarray) -> np.ndarray:
            ticks = plan.controls(population)
            steps = planner.steps
            frames = planner.rollout(plan.state0, hold(ticks, self.planning_steps),
                                     record_every=self.planning_steps * self.config.frame_ticks)
            evaluated["rollouts"] += ticks.shape[0]
            evaluated["steps"] += planner.steps - steps
            evaluated["unstable"] += int(planner.unstable.sum())
            return self._cost(call, plan.params, frames, planner)

        def progress(iteration: int, best: float) -> None:
            self.on_event(Event("iteration", phase=label, iteration=iteration + 1,
                                iterations=config.iterations, best_cost=best))

        optimizing = time.perf_counter()
        std = plan.keypoints.decision_std(primitive.motion.spread, primitive.motion.spread_angle)
        solution = optimize(cost, np.zeros(std.size), std, config=config,
                            rng=np.random.default_rng(seed),
                            on_iteration=progress)
        record.seconds["optimize"] = time.perf_counter() - optimizing
        record.best_cost_per_iteration = list(solution.best_cost_per_iteration)
        record.mean_cost_per_iteration = list(solution.mean_cost_per_iteration)
        record.rollouts = evaluated["rollouts"]
        record.physics_steps = evaluated["steps"]
        record.planning_dt = planner.dt
        record.unstable_rollouts = evaluated["unstable"]
        return solution

    def _execute(self, call: PhaseCall, plan: _Plan, solution: CEMResult,
                 record: PhaseResult) -> None:
        """Choose among the final elites as executed at the world's timestep; execute it."""
        primitive, roles, sim = call.primitive, call.roles, self.run.sim
        count = self.config.execute_elites or len(solution.elites)
        elites = solution.elites[:count]
        chosen = 0
        if len(elites) > 1:
            steps = self.timing.control_steps
            frames = sim.rollout(plan.state0, hold(plan.controls(elites), steps),
                                 record_every=steps * self.config.frame_ticks)
            costs = self._cost(call, plan.params, frames, sim)
            met = self._success_per_sample(primitive, frames.last(), roles, plan.params)
            chosen = int(np.lexsort((costs, ~met))[0])   # success first, then the lowest cost
        z = elites[chosen]
        record.executed_elites, record.chosen_elite = len(elites), chosen
        record.chosen_sample = [float(x) for x in z]
        record.keypoints = keypoint_records(plan.keypoints, z)
        record.planned_cost = float(solution.elite_costs[chosen])

        ctrl = hold(plan.controls(z[None])[0], self.timing.control_steps)
        final, frames = sim.replay(plan.state0, ctrl, record_every=self.timing.control_steps
                                   * self.config.frame_ticks, data=self.run.data)
        self.run.motions.append((plan.state0, ctrl))
        self.run.state = final
        given = plan.keypoints.grip[np.isfinite(plan.keypoints.grip)]
        self.run.grip = float(given[-1]) if given.size else self.run.grip
        record.executed_cost = float(self._cost(call, plan.params, frames, sim)[0])
        last = frames.last()
        end = self._success(primitive, last, roles, plan.params)
        record.success = with_start(end, plan.start_success)
        record.end = self._end_state(last)
        executed_ok = all(c.holds for c in end)
        record.planned_success = executed_ok if self.run.planner is sim else \
            self._planned_success(call, plan, z)
        first = next((c for c in record.success if not c.holds), None)
        record.status = "succeeded" if first is None else "failed"
        if first is not None:
            record.failure = clause_failure("success", first)
            if record.planned_success:
                record.failure += (
                    f"; the planned motion met every success clause at the "
                    f"{_ms(self.run.planner.dt)} planning timestep but not as executed at "
                    f"{_ms(sim.dt)} (planned cost {record.planned_cost:.3g}, executed cost "
                    f"{record.executed_cost:.3g})")

    def _planned_success(self, call: PhaseCall, plan: _Plan, z: np.ndarray) -> bool:
        """Whether the chosen motion met its success clauses in its planning rollout."""
        planner = self.run.planner
        frames = planner.rollout(plan.state0, hold(plan.controls(z[None]), self.planning_steps),
                                 record_every=self.planning_steps * self.config.frame_ticks)
        return bool(self._success_per_sample(call.primitive, frames.last(), call.roles,
                                             plan.params)[0])

    # ----------------------------------------------------------------------------- helpers

    def _requires(self, checked: tuple[Requirement, ...], roles: Mapping[str, int],
                  frames: Frames, record: PhaseResult) -> None:
        for requirement in checked:
            test = self.evaluator.guarded(requirement.test, f"requires `{requirement.text}`")
            holds = bool(np.all(test(frames, *(roles[r] for r in requirement.roles))))
            record.requires.append(ClauseResult(requirement.text, requirement.origin, holds))
        failed = [c for c in record.requires if not c.holds]
        if failed:
            raise PhaseError(f"requires `{failed[0].text}` ({failed[0].origin}) is false at the "
                             "phase's start")

    def _success(self, primitive: Primitive, frames: Frames, roles: dict[str, int],
                 params: dict[str, Any]) -> list[ClauseResult]:
        features = self.evaluator.call(primitive.features, Context(frames, roles, params),
                                       "resolve")
        return self.evaluator.judge(primitive.success,
                                    Context(frames, roles, params, features), "success")

    def _success_per_sample(self, primitive: Primitive, frames: Frames, roles: dict[str, int],
                            params: dict[str, Any]) -> np.ndarray:
        features = self.evaluator.call(primitive.features, Context(frames, roles, params),
                                       "resolve")
        return self.evaluator.holds_per_sample(primitive.success,
                                               Context(frames, roles, params, features),
                                               "success")

    def _controls(self, plan: KeypointSet, primitive: Primitive, start: HandPose) -> Controls:
        grip = self.run.grip

        def controls(z: np.ndarray) -> np.ndarray:
            """(N, M, nu) robot controls per control tick; callers hold them for a tick."""
            pos, yaw, pitch, roll, closing = hand_targets(plan, z, start, grip,
                                                          duration=primitive.motion.duration,
                                                          timing=self.timing)
            return self.world.robot.controls(pos, yaw, pitch, closing, roll)
        return controls

    def _cost(self, call: PhaseCall, params: dict[str, Any], frames: Frames,
              sim: Simulator) -> np.ndarray:
        """(B,) cost of each rollout of `sim`'s last call: final cost on the last state + weight
        x mean progress; a diverged rollout or a non-finite cost costs UNSTABLE_COST."""
        primitive, roles = call.primitive, call.roles
        batch = frames.batch
        with np.errstate(all="ignore"):
            last = frames.last()
            features = self.evaluator.call(primitive.features, Context(last, roles, params),
                                           "resolve")
            final = self.evaluator.call(primitive.cost_final,
                                        Context(last, roles, params, features), "cost final")
            total = np.broadcast_to(np.asarray(final, dtype=float), (batch, 1))[:, 0]
            if primitive.cost_progress is not None and primitive.progress_weight:
                features = self.evaluator.call(primitive.features,
                                               Context(frames, roles, params), "resolve")
                steps = self.evaluator.call(primitive.cost_progress,
                                            Context(frames, roles, params, features),
                                            "cost progress")
                steps = np.broadcast_to(np.asarray(steps, dtype=float), (batch, frames.steps))
                total = total + primitive.progress_weight * steps.mean(axis=1)
        total = np.asarray(total, dtype=float)
        return np.where(sim.unstable | ~np.isfinite(total), UNSTABLE_COST, total)

    def _end_state(self, last: Frames) -> EndState:
        """Contacts, finger contacts, what the hand holds, opening and hand pose at the end."""
        table = self.world.entities
        names = [e.name for e in table.entities]
        contact, fingers = last.contact[0, 0], last.fingers[0, 0]
        gripper = table.index("gripper")
        holds = IMPLEMENTATIONS["holding"]
        hand = self.run.hand()
        return EndState(
            contacts=[[names[i], names[j]] for i in range(len(names))
                      for j in range(i + 1, len(names)) if contact[i, j]],
            finger_contacts={names[e]: [side for side, on in zip(("left", "right"), fingers[e],
                                                                 strict=True) if on]
                             for e in range(len(names)) if fingers[e].any()},
            holding=[e.name for e in table.entities
                     if e.kind == "Object" and bool(holds(last, gripper, e.index)[0, 0])],
            opening=float(last.opening[0, 0]),
            hand_position=[float(x) for x in hand.position],
            hand_yaw=float(hand.yaw), hand_pitch=float(hand.pitch), hand_roll=float(hand.roll))


def planning_steps(timing: Timing, planning_dt: float) -> int:
    """Physics steps per control tick at `planning_dt`; ValueError if it does not divide it or
    is below MIN_PLANNING_DT (a finer step only multiplies the time of every rollout)."""
    if not math.isfinite(planning_dt) or planning_dt < MIN_PLANNING_DT:
        raise ValueError(f"planning_dt {planning_dt:g} s is below the minimum of "
                         f"{MIN_PLANNING_DT:g} s")
    steps = round(timing.control_dt / planning_dt)
    if steps < 1 or not math.isclose(steps * planning_dt, timing.control_dt):
        raise ValueError(f"planning_dt {planning_dt:g} s must divide the control period "
                         f"{timing.control_dt:g} s")
    return steps


def keypoint_records(plan: KeypointSet, z: np.ndarray) -> list[KeypointRecord]:
    """Each keypoint in the start state and as executed with the chosen sample's offsets."""
    position, yaw, pitch, roll = plan.apply(z[None])

    def given(value: float) -> float | None:
        return float(value) if math.isfinite(value) else None

    return [KeypointRecord(name, [float(x) for x in plan.position[i]],
                           [float(x) for x in position[0, i]], given(yaw[0, i]),
                           given(pitch[0, i]), given(plan.grip[i]), given(roll[0, i]))
            for i, name in enumerate(plan.names)]


def _nan(value: float | None) -> float:
    return math.nan if value is None else value


def _ms(dt: float) -> str:
    return f"{dt * 1000:g} ms"
