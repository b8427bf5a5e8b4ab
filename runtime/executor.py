"""Run a compiled program on a MuJoCo world: binding, Exec(P) by CEM, strategies phase by phase.

Exec(P) (DESIGN.md): check `requires`, evaluate the keypoints in the start state (the CEM mean),
sample keypoint offsets, turn every sample into hand targets and robot controls at once, run the
population as one native batched rollout, cost it vectorized over samples and time (unstable
rollouts cost `UNSTABLE_COST`), refit, and finally replay the best motion from the start state and
judge each success clause on its terminal state. A strategy binds its roles once, evaluates its
lets in the initial state, and runs its phases in order; each phase's arguments are evaluated just
in time, in the state the previous phase left. Problems of the program or the scene become reported
failures in the `RunResult`, never exceptions.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from rapid_dsl.runtime.binding import BindingError, bind, explain_no_binding
from rapid_dsl.runtime.cem import CEMConfig, optimize
from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.motion import KeypointSet, Timing, hand_targets
from rapid_dsl.runtime.program import (
    Checks,
    Comparison,
    Context,
    Param,
    Phase,
    Primitive,
    Program,
    Requirement,
    Strategy,
    truth,
)
from rapid_dsl.runtime.results import ClauseResult, PhaseResult, RunResult, format_value, plain
from rapid_dsl.runtime.simulate import Simulator, hold
from rapid_dsl.runtime.world import World

UNSTABLE_COST = 1e6          # cost of a diverged rollout or a non-finite cost
BINDING_LIMIT = 64           # bindings enumerated to report ambiguity


@dataclass(frozen=True, slots=True, kw_only=True)
class RunConfig:
    seed: int | None = None          # None: the primitive's `optimize { seed }`, else 0
    samples: int | None = None       # overrides every primitive's budget when given
    iterations: int | None = None
    nthread: int = 2
    control_steps: int = 10          # physics steps per control tick
    frame_ticks: int = 5             # control ticks per recorded frame (costs use the frames)
    planning_dt: float | None = 0.004  # s, timestep of the CEM's rollouts (None: the world's);
                                     # the best motion is replayed, and judged, at the world's
    settle: float = 0.5              # s
    grip_dwell: float = 0.4          # s


@dataclass(frozen=True, slots=True)
class Event:
    """Progress of a run, for a progress display."""

    kind: Literal["binding", "phase", "iteration", "replay", "phase_done"]
    phase: str = ""
    iteration: int = 0
    iterations: int = 0
    best_cost: float = math.nan
    message: str = ""


class ArgumentError(ValueError):
    """Arguments of a primitive entry that do not match its params (bad input)."""


class _PhaseError(Exception):
    """A phase cannot run: arguments out of range, a false requirement, a failed solve."""


Locate = Callable[[BaseException], str | None]
Arguments = Mapping[str, Any] | Callable[[], Mapping[str, Any]]


class Executor:
    """Runs declarations of one compiled program on one world."""

    def __init__(self, program: Program, world: World, *, config: RunConfig | None = None,
                 on_event: Callable[[Event], None] | None = None,
                 locate: Locate | None = None) -> None:
        self.program = program
        self.world = world
        self.config = config or RunConfig()
        self.on_event = on_event or (lambda event: None)
        self.locate = locate or (lambda exc: None)
        self.timing = Timing(dt=world.dt, control_steps=self.config.control_steps,
                             settle=self.config.settle, grip_dwell=self.config.grip_dwell)
        self.planning_dt = self.config.planning_dt or world.dt
        self.planning_steps = round(self.timing.control_dt / self.planning_dt)   # per tick
        if self.planning_steps < 1 or not math.isclose(
                self.planning_steps * self.planning_dt, self.timing.control_dt):
            raise ValueError(f"planning_dt {self.planning_dt} s must divide the control period "
                             f"{self.timing.control_dt} s")
        self.motions: list[tuple[np.ndarray, np.ndarray]] = []   # (state0, ctrl) per replay

    # ---------------------------------------------------------------------------- entry points

    def run(self, entry: str, *, pins: Mapping[str, str] | None = None,
            arguments: Mapping[str, Any] | None = None, scene: str = "") -> RunResult:
        """Bind `entry`'s roles in the world's start state and execute it.

        Raises BindingError for malformed pins and ArgumentError for arguments that do not fit a
        primitive entry's params (both bad input); everything else is reported in the result.
        """
        try:
            decl = self.program.declaration(entry)
        except KeyError:
            raise ArgumentError(f"the program declares no primitive or strategy `{entry}`") \
                from None
        kind: Literal["primitive", "strategy"] = "strategy" if isinstance(decl, Strategy) \
            else "primitive"
        seed = self._seed(decl)
        result = RunResult(self.program.path, entry, kind, scene, seed)
        if isinstance(decl, Primitive):
            self._check_arguments(decl, arguments or {})
        elif arguments:
            raise ArgumentError(f"`{entry}` is a strategy: it takes no --arg (its phases compute "
                                "their own arguments)")
        started = time.perf_counter()
        self.motions = []
        self.sim = Simulator(self.world, nthread=self.config.nthread)
        self.planner = self.sim if self.planning_dt == self.world.dt else \
            Simulator(self.world, nthread=self.config.nthread, timestep=self.planning_dt)
        self.data = self.world.make_data()
        self.state = self.sim.initial_state(self.data)
        self.grip = 0.0
        try:
            roles = self._bind(decl, pins or {}, result)
            if roles is not None:
                if isinstance(decl, Primitive):
                    self._run_primitive(decl, roles, dict(arguments or {}), result)
                else:
                    self._run_strategy(decl, roles, result)
            result.final_poses = self._poses()
        finally:
            self.sim.close()
            self.planner.close()
        result.seconds["total"] = time.perf_counter() - started
        return result

    def states(self, every: int) -> np.ndarray:
        """(T, nstate) states of every replayed motion, one per `every` physics steps (video)."""
        with Simulator(self.world, nthread=1) as sim:
            if not self.motions:
                return sim.initial_state()[None]
            parts = [sim.trajectory(state0, ctrl, every=every) for state0, ctrl in self.motions]
        return np.concatenate(parts)

    # ---------------------------------------------------------------------------------- binding

    def _bind(self, decl: Primitive | Strategy, pins: Mapping[str, str],
              result: RunResult) -> dict[str, int] | None:
        frames = self._frames()
        roles = [(r.name, r.kind) for r in decl.roles]
        names = [f"requires[{i}] {req.text}" for i, req in enumerate(decl.requires)]
        requires = [(name, req.roles) for name, req in zip(names, decl.requires, strict=True)]
        relations = {name: self._guarded(req.test, f"requires `{req.text}`")
                     for name, req in zip(names, decl.requires, strict=True)}
        try:
            found = bind(roles, requires, frames, fixed=pins, relations=relations,
                         limit=BINDING_LIMIT)
            if not found:
                reason = explain_no_binding(roles, requires, frames, fixed=pins,
                                            relations=relations)
        except _PhaseError as exc:
            result.failure = str(exc)
            return None
        if not found:
            for name, req in zip(names, decl.requires, strict=True):
                reason = reason.replace(f"{name}({', '.join(req.roles)})", req.text)
            result.failure = reason
            self.on_event(Event("binding", message=reason))
            return None
        result.binding = found[0]
        if len(found) > 1:
            count = f"at least {len(found)}" if len(found) == BINDING_LIMIT else str(len(found))
            others = "; ".join(_binding_text(b) for b in found[1:4])
            result.binding_note = (f"{count} bindings satisfy the roles and requires; using the "
                                   f"first ({_binding_text(found[0])}). Others: {others}. Pin "
                                   "roles with --bind role=entity.")
        self.on_event(Event("binding", message=_binding_text(found[0])))
        table = self.world.entities
        return {role: table.index(entity) for role, entity in found[0].items()}

    # ------------------------------------------------------------------------------ primitives

    def _run_primitive(self, primitive: Primitive, roles: dict[str, int],
                       arguments: dict[str, Any], result: RunResult) -> None:
        phase = self._execute(primitive, primitive.name, primitive.origin, roles, arguments)
        result.phases.append(phase)
        result.success = phase.success
        result.succeeded = phase.succeeded
        if not phase.succeeded:
            result.failure = phase.failure

    def _run_strategy(self, strategy: Strategy, roles: dict[str, int], result: RunResult) -> None:
        try:
            lets = {} if strategy.lets is None else \
                self._call(strategy.lets, Context(self._frames(), roles), "let")
        except _PhaseError as exc:
            result.failure = str(exc)
            return
        stopped = False
        for phase in strategy.phases:
            primitive = self.program.primitive(phase.primitive)
            names = {p: self.world.entities.entities[roles[s]].name for p, s in phase.role_map}
            if stopped:
                result.phases.append(PhaseResult(phase.name, primitive.name, phase.origin, names))
                continue
            mapped = {p: roles[s] for p, s in phase.role_map}

            def arguments(phase: Phase = phase) -> dict[str, Any]:
                if phase.arguments is None:
                    return {}
                return self._call(phase.arguments, Context(self._frames(), roles, lets=lets),
                                  f"arguments of phase `{phase.name}`")
            record = self._execute(primitive, phase.name, phase.origin, mapped, arguments,
                                   phase.unchecked_requires, roles)
            result.phases.append(record)
            if not record.succeeded and result.failure is None:
                result.failure = f"phase `{phase.name}`: {record.failure}"
            # A phase that could not run leaves nothing for the next ones to start from.
            stopped = record.status == "failed" and not record.rollouts
        try:
            context = Context(self._frames(), roles, lets=lets)
            result.success = self._judge(strategy.success, context)
        except _PhaseError as exc:
            result.failure = result.failure or str(exc)
            return
        if strategy.success.clauses:
            result.succeeded = all(c.holds for c in result.success) and not stopped
        else:   # no success block: the strategy succeeds when every phase has
            result.succeeded = all(p.succeeded for p in result.phases)
        first = next((c for c in result.success if not c.holds), None)
        if result.succeeded:
            result.failure = None   # a phase may fail its own success and the strategy still hold
        elif result.failure is None and first is not None:
            result.failure = _clause_failure("strategy success", first)

    def _execute(self, primitive: Primitive, name: str, origin: str, roles: dict[str, int],
                 arguments: Arguments, checked: tuple[Requirement, ...] = (),
                 checked_roles: Mapping[str, int] | None = None) -> PhaseResult:
        """Exec(P) from the current state; leaves the state at the end of the best motion.

        `arguments` may be a function evaluated first (a phase's just-in-time arguments);
        `checked` are requirements tested next, over `checked_roles` (a strategy's roles).
        """
        self.on_event(Event("phase", phase=name, message=primitive.name,
                            iterations=self._cem_config(primitive).iterations))
        started = time.perf_counter()
        record = self._exec(primitive, name, origin, roles, arguments, checked, checked_roles)
        record.seconds["total"] = time.perf_counter() - started
        best = record.best_cost_per_iteration[-1] if record.best_cost_per_iteration else math.nan
        self.on_event(Event("phase_done", phase=name, best_cost=best, message=record.status))
        return record

    def _exec(self, primitive: Primitive, name: str, origin: str, roles: dict[str, int],
              arguments: Arguments, checked: tuple[Requirement, ...],
              checked_roles: Mapping[str, int] | None) -> PhaseResult:
        names = {r: self.world.entities.entities[i].name for r, i in roles.items()}
        record = PhaseResult(name, primitive.name, origin, names)
        started = time.perf_counter()
        try:
            given = arguments() if callable(arguments) else arguments
            params = self._params(primitive, roles, given, record)
            self._requires(checked, checked_roles or roles, record)
            plan, std, start_pose = self._initialise(primitive, roles, params)
        except _PhaseError as exc:
            record.status, record.failure = "failed", str(exc)
            return record
        record.seconds["init"] = time.perf_counter() - started

        config = self._cem_config(primitive)
        record.samples, record.iterations = config.samples, config.iterations
        rng = np.random.default_rng(self._seed(primitive))
        ctrl_of = self._controls(plan, primitive, start_pose)
        state0 = self.state.copy()
        evaluated = {"rollouts": 0, "steps": 0, "unstable": 0}

        def cost(population: np.ndarray) -> np.ndarray:
            ticks = ctrl_of(population)
            steps = self.planner.steps
            frames = self.planner.rollout(
                state0, hold(ticks, self.planning_steps),
                record_every=self.planning_steps * self.config.frame_ticks)
            evaluated["rollouts"] += ticks.shape[0]
            evaluated["steps"] += self.planner.steps - steps
            unstable = self.planner.unstable
            evaluated["unstable"] += int(unstable.sum())
            costs = self._cost(primitive, roles, params, frames)
            return np.where(unstable | ~np.isfinite(costs), UNSTABLE_COST, costs)

        def progress(iteration: int, best: float) -> None:
            self.on_event(Event("iteration", phase=name, iteration=iteration + 1,
                                iterations=config.iterations, best_cost=best))

        optimizing = time.perf_counter()
        try:
            solution = optimize(cost, np.zeros(std.size), std, config=config, rng=rng,
                                on_iteration=progress)
        except _PhaseError as exc:
            record.status, record.failure = "failed", str(exc)
            return record
        record.seconds["optimize"] = time.perf_counter() - optimizing
        record.best_cost_per_iteration = list(solution.best_cost_per_iteration)
        record.mean_cost_per_iteration = list(solution.mean_cost_per_iteration)
        record.rollouts = evaluated["rollouts"]
        record.physics_steps = evaluated["steps"]
        record.planning_dt = self.planning_dt
        record.unstable_rollouts = evaluated["unstable"]

        replaying = time.perf_counter()
        self.on_event(Event("replay", phase=name, best_cost=solution.best_cost))
        ctrl = hold(ctrl_of(solution.best[None])[0], self.timing.control_steps)
        final, frames = self.sim.replay(state0, ctrl, record_every=self.timing.control_steps
                                        * self.config.frame_ticks, data=self.data)
        self.motions.append((state0, ctrl))
        self.state = final
        self.grip = float(_final_grip(plan, self.grip))
        try:
            record.final_cost = float(self._cost(primitive, roles, params, frames)[0])
            last = frames.last()
            features = self._call(primitive.features, Context(last, roles, params), "resolve")
            record.success = self._judge(primitive.success,
                                         Context(last, roles, params, features))
        except _PhaseError as exc:
            record.status, record.failure = "failed", str(exc)
            return record
        record.seconds["replay"] = time.perf_counter() - replaying
        first = next((c for c in record.success if not c.holds), None)
        record.status = "succeeded" if first is None else "failed"
        record.failure = None if first is None else _clause_failure("success", first)
        return record

    def _params(self, primitive: Primitive, roles: dict[str, int], arguments: Mapping[str, Any],
                record: PhaseResult) -> dict[str, Any]:
        """Given arguments over defaults, as plain SI values, range-checked."""
        values: dict[str, Any] = {}
        if primitive.defaults is not None:
            values.update(self._call(primitive.defaults, Context(self._frames(), roles),
                                     "param defaults"))
        values.update(arguments)
        params = {}
        for param in primitive.params:
            if param.name not in values:
                raise _PhaseError(f"param `{param.name}` of `{primitive.name}` has no value")
            value = _plain_param(param, values[param.name])
            params[param.name] = value
            record.arguments[param.name] = plain(value) if param.shape != "bool" else bool(value)
            record.units[param.name] = param.unit
            problem = _out_of_range(param, value)
            if problem:
                raise _PhaseError(problem)
        return params

    def _requires(self, checked: tuple[Requirement, ...], roles: Mapping[str, int],
                  record: PhaseResult) -> None:
        frames = self._frames()
        for requirement in checked:
            holds = self._holds(requirement, frames, roles)
            record.requires.append(ClauseResult(requirement.text, requirement.origin, holds))
        failed = [c for c in record.requires if not c.holds]
        if failed:
            raise _PhaseError(f"requires `{failed[0].text}` ({failed[0].origin}) is false at the "
                              "phase's start")

    def _holds(self, requirement: Requirement, frames: Frames, roles: Mapping[str, int]) -> bool:
        test = self._guarded(requirement.test, f"requires `{requirement.text}`")
        return bool(np.all(test(frames, *(roles[r] for r in requirement.roles))))

    def _initialise(self, primitive: Primitive, roles: dict[str, int],
                    params: dict[str, Any]) -> tuple[KeypointSet, np.ndarray, Any]:
        """Keypoints in the start state (the CEM mean) and the initial standard deviation."""
        frames = self._frames()
        features = self._call(primitive.features, Context(frames, roles, params), "resolve")
        keypoints = self._call(primitive.motion.keypoints,
                               Context(frames, roles, params, features), "motion keypoints")
        plan = KeypointSet.from_keypoints(keypoints)
        if not np.all(np.isfinite(plan.position)):
            bad = plan.names[int(np.flatnonzero(~np.isfinite(plan.position).all(axis=1))[0])]
            raise _PhaseError(f"keypoint `{bad}` is not a finite point in the start state")
        std = plan.decision_std(primitive.motion.spread, primitive.motion.spread_angle)
        self.sim.set_state(self.data, self.state)
        return plan, std, self.world.robot.hand_pose(self.data)

    def _controls(self, plan: KeypointSet, primitive: Primitive,
                  start_pose: Any) -> Callable[[np.ndarray], np.ndarray]:
        grip = self.grip

        def controls(z: np.ndarray) -> np.ndarray:
            """(N, M, nu) robot controls per control tick; callers hold them for a tick."""
            pos, yaw, pitch, closing = hand_targets(plan, z, start_pose, grip,
                                                    duration=primitive.motion.duration,
                                                    timing=self.timing)
            return self.world.robot.controls(pos, yaw, pitch, closing)
        return controls

    def _cost(self, primitive: Primitive, roles: dict[str, int], params: dict[str, Any],
              frames: Frames) -> np.ndarray:
        """(B,) cost of each rollout: final cost on the last state + weight x mean progress."""
        batch = frames.batch
        with np.errstate(all="ignore"):
            last = frames.last()
            features = self._call(primitive.features, Context(last, roles, params), "resolve")
            final = self._call(primitive.cost_final, Context(last, roles, params, features),
                               "cost final")
            total = np.broadcast_to(np.asarray(final, dtype=float), (batch, 1))[:, 0]
            if primitive.cost_progress is not None and primitive.progress_weight:
                features = self._call(primitive.features, Context(frames, roles, params),
                                      "resolve")
                steps = self._call(primitive.cost_progress,
                                   Context(frames, roles, params, features), "cost progress")
                steps = np.broadcast_to(np.asarray(steps, dtype=float), (batch, frames.steps))
                total = total + primitive.progress_weight * steps.mean(axis=1)
        return np.asarray(total, dtype=float)

    def _judge(self, checks: Checks, context: Context) -> list[ClauseResult]:
        with np.errstate(all="ignore"):
            values = self._call(checks.evaluate, context, "success")
        results = []
        for info, value in zip(checks.clauses, values, strict=True):
            holds = bool(np.all(truth(value)))
            if isinstance(value, Comparison):
                results.append(ClauseResult(info.text, info.origin, holds, plain(value.lhs),
                                            plain(value.rhs), info.unit))
            else:
                results.append(ClauseResult(info.text, info.origin, holds))
        return results

    # ---------------------------------------------------------------------------------- helpers

    def _frames(self) -> Frames:
        """The current state as Frames with B=1, T=1."""
        self.sim.set_state(self.data, self.state)
        pose = self.world.robot.hand_pose(self.data)
        ctrl = self.world.robot.hold(pose, self.grip)
        return self.sim.rollout(self.state, ctrl[None, None], record_every=1).first()

    def _poses(self) -> dict[str, dict[str, list[float]]]:
        frames = self._frames()
        return {e.name: {"position": [float(x) for x in frames.pos[0, 0, e.index]],
                         "quat": [float(x) for x in frames.quat[0, 0, e.index]]}
                for e in self.world.entities.entities}

    def _call(self, function: Callable[..., Any], context: Context, what: str) -> Any:
        return self._guarded(function, what)(context)

    def _guarded(self, function: Callable[..., Any], what: str) -> Callable[..., Any]:
        """Run generated code; its errors become phase failures that name the `.rapid` line."""
        def call(*args: Any) -> Any:
            try:
                return function(*args)
            except _PhaseError:
                raise
            except Exception as exc:  # generated code and the solver raise many types
                where = self.locate(exc)
                place = f" at {where}" if where else ""
                message = str(exc) or type(exc).__name__
                raise _PhaseError(f"evaluating {what}{place} failed: {message}") from None
        return call

    def _seed(self, decl: Primitive | Strategy) -> int:
        if self.config.seed is not None:
            return self.config.seed
        if isinstance(decl, Primitive) and decl.optimize.seed is not None:
            return decl.optimize.seed
        return 0

    def _cem_config(self, primitive: Primitive) -> CEMConfig:
        samples = self.config.samples or primitive.optimize.samples
        iterations = self.config.iterations or primitive.optimize.iterations
        elites = max(1, min(primitive.optimize.elites, samples // 2 or 1))
        return CEMConfig(samples=samples, elites=elites, iterations=iterations)

    def _check_arguments(self, primitive: Primitive, arguments: Mapping[str, Any]) -> None:
        known = {p.name: p for p in primitive.params}
        for name in arguments:
            if name not in known:
                listed = ", ".join(known) or "none"
                raise ArgumentError(f"`{primitive.name}` has no param `{name}`; its params: "
                                    f"{listed}")
        missing = [p.name for p in primitive.params if not p.has_default
                   and p.name not in arguments]
        if missing:
            raise ArgumentError(f"`{primitive.name}` needs --arg for: {', '.join(missing)}")


def _plain_param(param: Param, value: Any) -> Any:
    array = np.asarray(value, dtype=float)
    if param.shape == "vector":
        return array.reshape(-1, 3)[0].copy()
    if param.shape == "bool":
        return bool(np.all(np.asarray(value)))
    return float(array.reshape(-1)[0])


def _out_of_range(param: Param, value: Any) -> str | None:
    size = float(np.linalg.norm(value)) if param.shape == "vector" else value
    if param.shape == "bool" or (param.low is None and param.high is None):
        return None
    low = -math.inf if param.low is None else param.low
    high = math.inf if param.high is None else param.high
    if not math.isfinite(size) or not low <= size <= high:
        what = f"|{param.name}|" if param.shape == "vector" else param.name
        bounds = f"[{format_value(param.low, param.unit)}, {format_value(param.high, param.unit)}]"
        return (f"argument {what} = {format_value(size, param.unit)} is outside its range "
                f"{bounds}")
    return None


def _final_grip(plan: KeypointSet, grip: float) -> float:
    given = plan.grip[np.isfinite(plan.grip)]
    return float(given[-1]) if given.size else grip


def _binding_text(binding: Mapping[str, str]) -> str:
    return ", ".join(f"{role}={entity}" for role, entity in binding.items())


def _clause_failure(block: str, clause: ClauseResult) -> str:
    if clause.value is None:
        return f"{block} clause `{clause.text}` ({clause.origin}) is false"
    return (f"{block} clause `{clause.text}` ({clause.origin}) is false: "
            f"{format_value(clause.value, clause.unit)} vs "
            f"{format_value(clause.bound, clause.unit)}")


__all__ = ["ArgumentError", "BindingError", "Event", "Executor", "RunConfig", "UNSTABLE_COST"]
