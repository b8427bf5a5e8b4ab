"""Run the example programs the way `rapidc run` does, for the runtime benchmarks.

Programs are checked, compiled and loaded in memory once, through the run session
(rapid_dsl/api/compilation.py, runtime/session.py); each run builds a fresh Executor on a world
built once per scene, so repeated runs measure the CEM, not the front end or scene loading.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent.parent
EXAMPLES = ROOT / "examples"
SCENES = EXAMPLES / "scenes"


class ExampleError(RuntimeError):
    """An example program or scene that does not load (the benchmark cannot run)."""


@dataclass
class Example:
    """A loaded example program and the world of its scene."""

    program_path: Path
    scene_path: Path
    session: Any     # rapid_dsl.runtime.session.Session
    world: Any       # rapid_dsl.runtime.scenes.world.World

    @property
    def loaded(self) -> Any:
        """The loaded program (rapid_dsl.runtime.loader.LoadedProgram)."""
        return self.session.loaded

    def run(self, *, seed: int, samples: int | None = None,
            iterations: int | None = None) -> Any:
        """One `rapidc run` of the example (no progress output); returns the RunResult.

        samples/iterations override every phase's budget, as `rapidc run --samples` does.
        """
        from rapid_dsl.runtime.config import RunConfig

        config = RunConfig(seed=seed, samples=samples, iterations=iterations)
        executor = self.session.executor(self.world, config)
        return self.session.execute(executor, scene=str(self.scene_path))


def load_example(program: str, scene: str) -> Example:
    """Check, compile and load examples/PROGRAM (its one strategy); build the world of
    examples/scenes/SCENE."""
    from rapid_dsl.api.compilation import ProgramError, compile_file
    from rapid_dsl.runtime.scenes.scene import SceneError, load_scene
    from rapid_dsl.runtime.session import Session

    program_path, scene_path = EXAMPLES / program, SCENES / scene
    try:
        compiled, checked = compile_file(str(program_path))
    except ProgramError as exc:
        raise ExampleError(str(exc)) from None
    if len(checked.strategies) != 1:
        raise ExampleError(f"{program_path} must declare exactly one strategy")
    session = Session(compiled)
    try:
        world = session.world(load_scene(scene_path))
    except SceneError as exc:
        raise ExampleError(f"{scene_path}: {exc}") from None
    return Example(program_path, scene_path, session, world)
