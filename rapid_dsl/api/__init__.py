"""rapid_dsl as a library: check, compile and run programs, getting data back (docs/api.md).

Each function returns dataclasses and raises `RapidError`, whose `exit_code` is the status
`rapidc` gives the same failure (2: bad input). Progress comes through callbacks, never output:
nothing here prints.

    from rapid_dsl import api

    checked = api.check("examples/flip_box.rapid")     # diagnostics, the IR, the module graph
    result = api.run("examples/flip_box.rapid", "examples/scenes/flip_box.yaml",
                     samples=16, iterations=2)          # a RunResult: phases, clauses, poses
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from rapid_dsl.api.compilation import ProgramError, choose_entry, compile_file
from rapid_dsl.frontend.driver import CheckResult, InputError, check_file, check_text

if TYPE_CHECKING:
    from rapid_dsl.runtime.compiled import CompiledProgram
    from rapid_dsl.runtime.config import Event
    from rapid_dsl.runtime.results import RunResult

__all__ = ["CheckResult", "RapidError", "check", "choose_entry", "compile", "run"]

Paths = Sequence[str | os.PathLike[str]]


class RapidError(Exception):
    """A failure `rapidc` would report with `exit_code` (2: the input is wrong)."""

    def __init__(self, message: str, exit_code: int = 2) -> None:
        super().__init__(message)
        self.message = message
        self.exit_code = exit_code


def check(path: str | os.PathLike[str], *, text: str | None = None, lint: bool = False,
          allowed_dirs: Paths = ()) -> CheckResult:
    """Check the program in `path` (or `text`, named `path`): its diagnostics, and what the front
    end made of it, kept when it has errors too (`module`, `graph`, `checked`). A program that
    does not check is a result, not an error; a file that cannot be read raises RapidError."""
    name = os.fspath(path)
    if text is not None:
        return check_text(text, name, lint=lint, allowed_dirs=allowed_dirs)
    try:
        return check_file(name, lint=lint, allowed_dirs=allowed_dirs)
    except InputError as exc:
        raise RapidError(exc.message) from None


def compile(path: str | os.PathLike[str], *, entry: str | None = None,  # noqa: A001
            allowed_dirs: Paths = ()) -> CompiledProgram:
    """The program in `path` compiled for the runtime: the generated module and the entry it
    runs. Raises RapidError when it cannot be read, does not check or has no runnable entry."""
    try:
        compiled, _ = compile_file(os.fspath(path), entry=entry, allowed_dirs=allowed_dirs)
    except ProgramError as exc:
        raise RapidError(str(exc)) from None
    return compiled


def run(path: str | os.PathLike[str], scene: str | os.PathLike[str], *,
        entry: str | None = None, pins: Mapping[str, str] | None = None,
        hints: Mapping[str, str] | None = None, best: bool = False,
        arguments: Mapping[str, Any] | None = None, seed: int | None = None,
        samples: int | None = None, iterations: int | None = None,
        allowed_dirs: Paths = (), on_event: Callable[[Event], None] | None = None) -> RunResult:
    """Check, compile, bind and execute the program on `scene`, as `rapidc run` does. `pins`
    fix roles to entities (`--bind`), `hints` prefer them (`--hint`), `best` takes the
    top-ranked of tied bindings; `arguments` are a primitive entry's, in SI units. Progress goes
    to `on_event`. A run that fails is a result (`succeeded` false); bad input raises
    RapidError."""
    from rapid_dsl.runtime.binding import BindingError
    from rapid_dsl.runtime.config import RunConfig
    from rapid_dsl.runtime.executor import ArgumentError, MemoryBudgetError
    from rapid_dsl.runtime.loader import LoadError
    from rapid_dsl.runtime.scenes.scene import SceneError, load_scene
    from rapid_dsl.runtime.session import AmbiguousBinding, Session

    compiled = compile(path, entry=entry, allowed_dirs=allowed_dirs)
    try:
        session = Session(compiled)
        world = session.world(load_scene(scene, allowed_dirs=allowed_dirs))
        choice = session.choose(world, dict(pins or {}), dict(hints or {}), best=best)
        executor = session.executor(world, RunConfig(seed=seed, samples=samples,
                                                     iterations=iterations), on_event=on_event)
        result = session.execute(executor, pins=choice.pins, arguments=arguments,
                                 scene=os.fspath(scene))
    except (SceneError, LoadError, BindingError, AmbiguousBinding, ArgumentError,
            MemoryBudgetError, ValueError) as exc:
        raise RapidError(str(exc)) from None
    result.binding_note = choice.note or result.binding_note
    return result
