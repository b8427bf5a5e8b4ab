"""One verification job: the program run on one scene (the scene itself or one variant).

A `Runner` holds the program loaded once per process (runtime/session.py) and runs it on the
scenes it is given, binding each as `rapidc run` does (pins, hints, `--best`), so a variant is
screened by the program's filters before anything moves and rejected if one is false
(runtime/screening.py). With a media folder, it writes one PNG strip of key frames of the
executed motion per job. Used through runtime/verification/worker.py, in the command's own process,
in worker processes and on cluster workers alike.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rapid_dsl.runtime.binding import BindingBudgetError
from rapid_dsl.runtime.config import RunConfig
from rapid_dsl.runtime.executor import Executor, MemoryBudgetError
from rapid_dsl.runtime.program import Strategy
from rapid_dsl.runtime.scenes.scene import Scene
from rapid_dsl.runtime.scenes.world import World
from rapid_dsl.runtime.session import AmbiguousBinding, Session
from rapid_dsl.runtime.verification.records import Record, failed_record, run_record

if TYPE_CHECKING:   # the job makes its runner: only its type is needed here
    from rapid_dsl.runtime.verification.job import VerifyJob

STRIP_FRAMES = 4                 # key frames side by side: the start, two between, the end
STRIP_SIZE = (320, 240)          # each frame's width and height [px]


class _Clock:
    def __init__(self) -> None:
        self.wall, self.cpu = time.perf_counter(), time.process_time()

    def read(self) -> dict[str, float]:
        return {"seconds": round(time.perf_counter() - self.wall, 3),
                "cpu_seconds": round(time.process_time() - self.cpu, 3)}


def media_name(index: int | None) -> str:
    """`scene.png` for the scene itself, `variant-0003.png` for variant 3."""
    return "scene.png" if index is None else f"variant-{index:04d}.png"


class Runner:
    """Runs one job's program on scenes; `threads` native threads per rollout batch."""

    def __init__(self, job: VerifyJob, threads: int = 1) -> None:
        self.job = job
        self.session = Session(job.program)
        self.config = RunConfig(nthread=threads, **job.run)
        decl = self.session.program.declaration(job.program.entry)
        self.primitives = {p.name: p.primitive for p in decl.phases} \
            if isinstance(decl, Strategy) else {}

    def run(self, index: int | None, scene: Scene) -> tuple[Record, dict[str, float]]:
        """The record of the run on `scene` (variant `index`, None: the scene itself) and its
        timing: wall `seconds` and `cpu_seconds` of this process (rollout threads included)."""
        clock = _Clock()
        job = self.job
        world = self.session.world(scene)
        try:
            choice = self.session.choose(world, job.pins, job.hints, best=job.best)
        except AmbiguousBinding as exc:
            message = (f"{exc} ({exc.ranking.count} in all); pin roles with --bind role=entity, "
                       "match names with --hint role=text, or take the top-ranked with --best")
            return failed_record("binding", message), clock.read()
        except BindingBudgetError as exc:   # a variant's added objects made the search too large
            return failed_record("binding", str(exc)), clock.read()
        executor = self.session.executor(world, self.config)
        try:
            result = self.session.execute(executor, pins=choice.pins, arguments=job.arguments,
                                          scene=scene.source or "")
        except MemoryBudgetError as exc:   # a variant's added objects made the run too large
            return failed_record("screening", str(exc)), clock.read()
        result.binding_note = choice.note or result.binding_note
        media = media_error = None
        if job.media is not None:
            media, media_error = self._media(index, world, executor)
        record = run_record(result, job.locations, primitives=self.primitives, media=media,
                            media_error=media_error)
        return record, clock.read()

    def _media(self, index: int | None, world: World, executor: Executor
               ) -> tuple[str | None, str | None]:
        """Write the key-frame strip; (its path, None) or (None, why not)."""
        import imageio.v2 as imageio

        from rapid_dsl.language.files import FileProblem, replacing
        from rapid_dsl.runtime.render import RenderError, frame_stride, render_frames

        assert self.job.media is not None
        path = Path(self.job.media) / media_name(index)
        try:
            states = executor.states(frame_stride(world, 30.0))
            picks = np.unique(np.linspace(0, len(states) - 1, STRIP_FRAMES).round().astype(int))
            width, height = STRIP_SIZE
            images = render_frames(world, states[picks], width=width, height=height)
            with replacing(path) as temporary:   # the front end checked it holds no input
                imageio.imwrite(temporary, np.concatenate(list(images), axis=1))
        except (RenderError, FileProblem) as exc:
            return None, f"cannot write {path}: {exc}"
        except OSError as exc:
            return None, f"cannot write {path}: {exc.strerror or exc}"
        return str(path), None
