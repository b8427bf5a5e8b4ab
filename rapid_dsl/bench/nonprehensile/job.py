"""What every benchmark run shares, sent once to each worker: the compiled programs and settings.

A run is a pure function of this job and its `Trial` (task, test scene, trial, seed, the scene
read back from its file), so its record is the same whichever process or cluster worker made it.
Light at import, like runtime/verification/job.py: workers unpickle it before they import mujoco.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rapid_dsl.runtime.compiled import CompiledProgram
from rapid_dsl.runtime.verification.job import digest

if TYPE_CHECKING:
    from rapid_dsl.bench.nonprehensile.harness import BenchRunner

FORMAT = "rapidc-bench-nonprehensile/1"
CONTROL = "control"           # the control's program key, and its trial in a run's key
CONTROL_TRIAL = 1000          # the control's trial number in its CEM seed


@dataclass(frozen=True, slots=True)
class BenchJob:
    strategies: dict[str, CompiledProgram]     # task key -> its compiled strategy
    control: CompiledProgram                   # tasks/control.rapid
    tasks: dict[str, str]                      # task key -> its module (tasks/__init__.py load)
    run: dict[str, Any] = field(default_factory=dict)   # RunConfig fields: samples, iterations
    media: str | None = None                   # no key frames: workers never need GL

    def settings(self) -> dict[str, Any]:
        return {"tasks": self.tasks, "run": self.run}

    def digest(self) -> str:
        return digest({"strategies": {k: p.source for k, p in self.strategies.items()},
                       "control": self.control.source, **self.settings()})

    def runner(self, threads: int) -> BenchRunner:
        from rapid_dsl.bench.nonprehensile.harness import BenchRunner

        return BenchRunner(self, threads)


@dataclass(frozen=True, slots=True)
class Trial:
    """One run: the task's strategy (trial 0, 1, ...) or the control (trial None) on a scene."""

    task: str
    scene_index: int
    trial: int | None
    seed: int
    scene: Any                     # runtime.scene.Scene, read back from its file
    scene_file: str

    @property
    def key(self) -> str:
        return run_key(self.task, self.scene_index, self.trial)


def run_key(task: str, scene: int, trial: int | None) -> str:
    """How a run is named in the journal: `T1/003/0`, `T1/003/control`."""
    return f"{task}/{scene:03d}/{CONTROL if trial is None else trial}"


def run_seed(test_seed: int, scene: int, trial: int | None) -> int:
    """The CEM seed of a run: a pure function of the test seed, the scene and the trial."""
    number = CONTROL_TRIAL if trial is None else trial
    return int(np.random.SeedSequence([test_seed, scene, number]).generate_state(1)[0])
