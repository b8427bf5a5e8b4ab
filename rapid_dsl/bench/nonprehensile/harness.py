"""One benchmark run: bind the strategy by the ranking, run it, judge the task's criterion.

A `BenchRunner` (made once per worker from a `BenchJob`, runtime/verification/worker.py) loads every
task's strategy and the control once. For a `Trial` it builds the world of the test scene, binds
the program automatically (runtime/session.py: the top-ranked binding, `best=True`, no pins; the
control's `target` is pinned to the task's object), runs it with the trial's seed and the job's
budgets, and measures the criterion on the final physical state (`final_state`: the executed
motion's first and last state, sensed as the builtins see them, so contacts are MuJoCo's). The
strategy's own outcome is recorded beside the verdict and never decides it, except that a run
that never moved (no binding, a filter rejected its scene) or stopped at a failed phase is a
failed trial, with its reason. Nothing here raises for a failed run.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from rapid_dsl.bench.nonprehensile.criteria import grasped_above
from rapid_dsl.bench.nonprehensile.spec import FinalState, Measure, Task
from rapid_dsl.bench.nonprehensile.tasks import load
from rapid_dsl.runtime.binding import BindingError
from rapid_dsl.runtime.config import RunConfig
from rapid_dsl.runtime.executor import MemoryBudgetError
from rapid_dsl.runtime.results import RunResult
from rapid_dsl.runtime.scenes.world import World
from rapid_dsl.runtime.session import Session
from rapid_dsl.runtime.simulate import Simulator

if TYPE_CHECKING:   # the job makes its runner: only its types are needed here
    from rapid_dsl.bench.nonprehensile.job import BenchJob, Trial

Record = dict[str, Any]


def final_state(world: World, motions: Sequence[tuple[np.ndarray, np.ndarray]] = ()
                ) -> FinalState:
    """The start state and the state after the last executed motion ((state0, ctrl) pairs, as
    `Executor.motions` holds them) as B=1, T=1 frames; the start state when nothing ran."""
    meshes = {obj.name: obj.mesh for obj in world.scene.objects if obj.mesh is not None}
    with Simulator(world, nthread=1) as sim:
        start = sim.initial_state()
        start_frames = _sensed(sim, world, start, None)
        if not motions:
            return FinalState(start_frames, start_frames, meshes)
        state0, ctrl = motions[-1]
        final = sim.trajectory(state0, ctrl, every=len(ctrl))[-1]
        return FinalState(_sensed(sim, world, final, ctrl[-1]), start_frames, meshes)


def _sensed(sim: Simulator, world: World, state: np.ndarray, ctrl: np.ndarray | None) -> Any:
    if ctrl is None:   # the start: hold the hand where it is, open
        data = world.make_data()
        sim.set_state(data, state)
        ctrl = world.robot.hold(world.robot.hand_pose(data), 0.0)
    return sim.rollout(state, np.asarray(ctrl)[None, None], record_every=1).first()


def control_measure(task: Task, state: FinalState) -> Measure:
    """The control's criterion: the task's object held above the task's support."""
    return grasped_above(state, task.target, task.support)


class BenchRunner:
    """The job's programs loaded once; `threads` native threads per rollout batch."""

    def __init__(self, job: BenchJob, threads: int = 1) -> None:
        self.job = job
        self.sessions = {key: Session(program) for key, program in job.strategies.items()}
        self.control = Session(job.control)
        self.tasks = {key: load(reference) for key, reference in job.tasks.items()}
        self.threads = threads

    def run(self, key: str, trial: Trial) -> tuple[Record, dict[str, float]]:
        wall, cpu = time.perf_counter(), time.process_time()
        task = self.tasks[trial.task]
        session = self.control if trial.trial is None else self.sessions[trial.task]
        pins = {"target": task.target} if trial.trial is None else {}
        world = session.world(trial.scene)
        config = RunConfig(nthread=self.threads, **self.job.run, seed=trial.seed)
        executor = session.executor(world, config)
        try:
            choice = session.choose(world, pins, {}, best=True)
            result = session.execute(executor, pins=choice.pins, scene=trial.scene_file)
        except (BindingError, MemoryBudgetError) as exc:   # a control's bad pin, or a budget
            result = RunResult(session.program.path, session.entry, "strategy",
                               trial.scene_file, trial.seed, failure=str(exc))
        else:
            result.binding_note = choice.note or result.binding_note
        state = final_state(world, executor.motions)
        judge: Callable[[FinalState], Measure] = task.criterion
        if trial.trial is None:
            judge = functools.partial(control_measure, task)
        record = trial_record(trial, result, state, judge)
        timing = {"seconds": round(time.perf_counter() - wall, 3),
                  "cpu_seconds": round(time.process_time() - cpu, 3)}
        return record, timing


def trial_record(trial: Trial, result: RunResult, state: FinalState,
                 judge: Callable[[FinalState], Measure]) -> Record:
    """The run's record: the strategy's own outcome, per phase, and the criterion's verdict."""
    data = result.to_json()
    phases = [{"name": p["name"], "primitive": p["primitive"], "status": p["status"],
               "on_fail": p["on_fail"], "failure": p["failure"]} for p in data["phases"]]
    stopped = next((p for p in phases if p["status"] == "failed" and p["on_fail"] == "stop"),
                   None)
    try:
        measure = judge(state)
        criterion: Record | None = {"success": bool(measure.success),
                                    "value": _finite(measure.value), "text": measure.text}
        reason = None if measure.success else measure.text
    except Exception as exc:   # a criterion that cannot read this state: the trial fails
        criterion, reason = None, f"the criterion could not be measured: {exc!r}"
    success = bool(criterion and criterion["success"])
    if not result.binding:
        success, reason = False, f"no binding: {result.failure}"
    elif result.rejected:
        success, reason = False, f"rejected by a filter: {result.failure}"
    elif stopped is not None:
        success, reason = False, f"phase `{stopped['name']}` failed: {stopped['failure']}"
    return {"key": trial.key, "task": trial.task, "scene": trial.scene_index,
            "trial": trial.trial, "seed": trial.seed, "scene_file": trial.scene_file,
            "binding": data["binding"], "binding_note": data["binding_note"],
            "outcome": data["outcome"], "strategy_failure": data["failure"], "phases": phases,
            "criterion": criterion, "success": success, "reason": None if success else reason,
            "final_poses": data["final_poses"]}


def lost_record(why: str) -> Record:
    """A run whose worker died twice (runtime/verification/backends.py drive): a failed trial."""
    return {"binding": {}, "binding_note": None, "outcome": "error", "strategy_failure": why,
            "phases": [], "criterion": None, "success": False, "reason": why,
            "final_poses": {}}


def _finite(value: float) -> float | None:
    value = float(value)
    return value if np.isfinite(value) else None
