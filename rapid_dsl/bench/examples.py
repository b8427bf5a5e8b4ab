"""Run the example programs the way `rapidc run` does, for the runtime benchmarks.

Programs are checked, compiled and loaded in memory once; each run builds a fresh Executor on a
world built once per scene, so repeated runs measure the CEM, not the front end or scene loading.
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
    loaded: Any      # rapid_dsl.runtime.loader.LoadedProgram
    world: Any       # rapid_dsl.runtime.world.World

    def run(self, *, seed: int, samples: int | None = None,
            iterations: int | None = None) -> Any:
        """One `rapidc run` of the example (no progress output); returns the RunResult.

        samples/iterations override every phase's budget, as `rapidc run --samples` does.
        """
        from rapid_dsl.runtime.executor import Executor, RunConfig

        config = RunConfig(seed=seed, samples=samples, iterations=iterations)
        executor = Executor(self.loaded.program, self.world, config=config,
                            locate=self.loaded.locate)
        entry = _entry(self.loaded)
        return executor.run(entry, scene=str(self.scene_path))


def load_example(program: str, scene: str) -> Example:
    """Check, compile and load examples/PROGRAM; build the world of examples/scenes/SCENE."""
    from rapid_dsl.commands.building import module_stem
    from rapid_dsl.compiler import compile_program
    from rapid_dsl.driver import InputError, check_file
    from rapid_dsl.runtime.loader import load
    from rapid_dsl.runtime.scene import SceneError, load_scene
    from rapid_dsl.runtime.world import build_world

    program_path, scene_path = EXAMPLES / program, SCENES / scene
    try:
        checked = check_file(str(program_path))
    except InputError as exc:
        raise ExampleError(exc.message) from None
    errors = [d for d in checked.diagnostics if d.is_error]
    if checked.program is None or errors:
        raise ExampleError(f"{program_path} does not check: {errors[0].message if errors else ''}")
    module = compile_program(checked.program)
    loaded = load(module.source, module_stem(str(program_path)))
    try:
        world = build_world(load_scene(scene_path))
    except SceneError as exc:
        raise ExampleError(f"{scene_path}: {exc}") from None
    return Example(program_path, scene_path, loaded, world)


def _entry(loaded: Any) -> str:
    strategies = loaded.program.strategies
    if len(strategies) != 1:
        raise ExampleError(f"{loaded.filename} must declare exactly one strategy")
    return str(strategies[0].name)
