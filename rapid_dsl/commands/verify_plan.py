"""`rapidc verify` after its options: check every input up front, then run the jobs.

`plan` turns the command line into a `Verification`: the compiled program (loaded here once, so a
module the loader refuses is exit 2 before any worker starts), the scene and ranges, the sampler,
the base scene's binding (an ambiguous one is refused as `rapidc run` refuses it), the run
settings and, with --resume, the runs an earlier report kept. `Verification.run` hands the jobs to
a backend (runtime/verification/backends.py, runtime/verification/cluster.py), journals each
finished run, and writes the report and the summary.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rapid_dsl import __version__
from rapid_dsl.commands.building import Checked, print_scene_problems
from rapid_dsl.commands.common import fail_usage, wants_color
from rapid_dsl.commands.run_options import RunInputs, design


class VerifyError(Exception):
    """Bad input, already reported; `status` is the exit status."""

    def __init__(self, status: int = 2) -> None:
        super().__init__(status)
        self.status = status


def _usage(message: str) -> VerifyError:
    fail_usage(message)
    return VerifyError(2)


def plan(args: argparse.Namespace, checked: Checked, given: RunInputs,
         gl_backend: str | None) -> Verification:
    """Check every input and setting; raises VerifyError (reported) for bad input.
    `gl_backend`: what this process renders with (--media), for the workers."""
    from rapid_dsl.api.compilation import clause_locations, compile_checked
    from rapid_dsl.runtime.loader import LoadError
    from rapid_dsl.runtime.session import Session
    from rapid_dsl.runtime.verification.job import VerifyJob, digest

    compiled = compile_checked(checked.program, args.program, given.entry)
    try:
        session = Session(compiled)
    except LoadError as exc:    # the loader refused the generated module; nothing of it ran
        raise _usage(str(exc)) from None
    scene, sampler = _scenes(args)
    settings = {"seed": args.cem_seed, "samples": args.samples, "iterations": args.iterations,
                **design(args)}
    world = session.world(scene)
    _check_settings(session, world, settings, given, args.jobs or 1)
    from rapid_dsl.commands.bind import choose

    chosen = choose(session.program, world, given.entry, given.pins, given.hints, best=args.best)
    if isinstance(chosen, int):
        raise VerifyError(chosen)   # an ambiguous binding, refused with its candidates
    media = str(Path(args.media).resolve()) if args.media is not None else None
    job = VerifyJob(compiled, settings, given.pins, given.hints, args.best, given.arguments,
                    clause_locations(checked.program), media)
    parts = {"program": digest(compiled.source), "scene": digest(scene.model_dump(mode="json")),
             "ranges": digest(repr(sampler.ranges)), "seed": digest(args.seed),
             "settings": digest(job.settings())}
    kind = "strategy" if given.entry in {s.name for s in checked.program.strategies} \
        else "primitive"
    header = {"format": _format(), "rapidc": __version__, "program": args.program,
              "entry": given.entry, "kind": kind, "scene": args.scene, "ranges": args.ranges,
              "seed": args.seed, "variants": args.variants, "settings": job.settings(),
              "fingerprint": parts}
    kept, journal = _previous(args.resume, header) if args.resume else ({}, None)
    inputs = [*checked.inputs, args.scene, *([args.ranges] if args.ranges else []),
              *(obj.mesh for obj in scene.objects if obj.mesh), *sampler.ranges.meshes]
    _check_outputs(args, inputs)
    return Verification(args, job, header, sampler, scene, gl_backend, inputs, kept,
                        resumed_journal=journal)


def page_inputs(args: argparse.Namespace, inputs: list[str]) -> list[str]:
    """What the --html page and the media strips may not replace: the run's inputs, and the
    report and journals it reads or writes."""
    from rapid_dsl.runtime.verification.report import journal_path

    reports = [p for p in (args.report, args.resume) if p is not None]
    return [*inputs, *reports, *(str(journal_path(p)) for p in reports)]


def _check_outputs(args: argparse.Namespace, inputs: list[str]) -> None:
    """Refuse, before anything runs, an --html page or a --media strip that would replace an
    input (the program, a file it uses, the scene, the ranges, a mesh, the report)."""
    from rapid_dsl.commands.verify_display import check_html
    from rapid_dsl.language.files import FileProblem, output_folder
    from rapid_dsl.runtime.verification.runner import media_name

    protected = page_inputs(args, inputs)
    if args.html is not None:
        problem = check_html(args.html, protected)
        if problem is not None:
            raise _usage(problem)
    if args.media is None:
        return
    try:
        with output_folder(args.media, inputs=protected) as media:
            for index in [None, *range(args.variants)]:
                if media.identity(media_name(index)) in media.inputs:
                    raise _usage(f"--media {args.media}: {media_name(index)} in it is one of "
                                 "the inputs")
    except FileProblem as exc:
        raise _usage(f"--media {args.media}: {exc}") from None


def _format() -> str:
    from rapid_dsl.runtime.verification.job import REPORT_FORMAT

    return REPORT_FORMAT


def _scenes(args: argparse.Namespace) -> tuple[Any, Any]:
    from rapid_dsl.runtime.scenes.scene import SceneError, load_scene
    from rapid_dsl.runtime.variants.ranges import load_ranges
    from rapid_dsl.runtime.variants.sampler import VariantError, VariantSampler

    try:
        scene = load_scene(args.scene, allowed_dirs=args.allowed_dirs)
        ranges = load_ranges(args.ranges, scene, allowed_dirs=args.allowed_dirs) \
            if args.ranges else None
    except SceneError as error:
        print_scene_problems(error)
        raise VerifyError(2) from None
    try:
        return scene, VariantSampler(scene, ranges)
    except VariantError as error:
        raise _usage(f"{args.scene}: {error}") from None


def _check_settings(session: Any, world: Any, settings: dict[str, Any],
                    given: RunInputs, jobs: int) -> None:
    """What Executor.run would refuse as bad input, refused once here instead of per job."""
    from rapid_dsl.runtime import memory
    from rapid_dsl.runtime.config import RunConfig
    from rapid_dsl.runtime.params import ArgumentError, check_arguments
    from rapid_dsl.runtime.program import Primitive

    try:
        session.executor(world, RunConfig(**settings))
    except ValueError as exc:   # a planning timestep that does not divide the control period
        raise _usage(f"--planning-dt: {exc}") from None
    try:   # the local jobs run at once; a cluster's workers are machines of their own
        memory.check(session.program, world, given.entry, RunConfig(**settings), copies=jobs)
    except memory.MemoryBudgetError as exc:
        raise _usage(str(exc)) from None
    decl = session.program.declaration(given.entry)
    if isinstance(decl, Primitive):
        try:
            check_arguments(decl, given.arguments)
        except ArgumentError as exc:
            raise _usage(str(exc)) from None


def _previous(path: str, header: dict[str, Any]
              ) -> tuple[dict[int | None, dict[str, Any]], Path | None]:
    """The runs an earlier report (or its journal) kept that this run can use, and the journal
    they were read from (None: the report)."""
    from rapid_dsl.runtime.verification.report import ReportProblem, read_previous

    try:
        before, records, journal = read_previous(path)
    except ReportProblem as exc:
        raise _usage(f"--resume: {exc}") from None
    old = before["fingerprint"]
    changed = [part for part, value in header["fingerprint"].items() if old[part] != value]
    if changed:
        raise _usage(f"--resume {path}: its {', '.join(changed)} differ from this run's; verify "
                     "again without --resume (or with the same inputs and options)")
    # a job lost twice is run again; variants past --variants are left out
    kept = {r["variant"]: r for r in records if r["outcome"] != "error"
            and (r["variant"] is None or r["variant"] < header["variants"])}
    return kept, journal


@dataclass
class Verification:
    args: argparse.Namespace
    job: Any                        # VerifyJob
    header: dict[str, Any]
    sampler: Any                    # VariantSampler
    scene: Any                      # Scene
    gl_backend: str | None
    inputs: list[str]
    records: dict[int | None, dict[str, Any]] = field(default_factory=dict)
    parameters: dict[int, dict[str, Any]] = field(default_factory=dict)
    resumed_journal: Path | None = None     # the journal --resume read, appended to if written

    def run(self) -> int:
        from rapid_dsl.commands.verify_display import VerifyProgress, print_report
        from rapid_dsl.runtime.variants.sampler import VariantError
        from rapid_dsl.runtime.verification.backends import drive
        from rapid_dsl.runtime.verification.report import (
            Journal,
            ReportProblem,
            assemble,
            check_output,
            journal_path,
            write_report,
        )

        args = self.args
        report_path = args.report or args.resume
        try:
            if report_path:
                check_output(report_path, self.inputs)
            journal = Journal(journal_path(report_path), self.header, self.records.values(),
                              inputs=self.inputs,
                              append=_same_file(self.resumed_journal,
                                                journal_path(report_path))) \
                if report_path else None
        except ReportProblem as exc:
            return fail_usage(str(exc))
        total = args.variants + 1
        progress = VerifyProgress(total, len(self.records), quiet=args.quiet,
                                  color=wants_color(args.color, sys.stderr))

        def done(index: int | None, record: dict[str, Any], timing: dict[str, float],
                 attempts: int) -> None:
            full = {"variant": index, "seed": None if index is None else args.seed,
                    "parameters": self.parameters.pop(index, None) if index is not None
                    else None, **record,
                    "execution": {"attempts": attempts, **timing}}
            self.records[index] = full
            if journal is not None:
                journal.append(full)
            progress.update(full)

        status: int | None = None
        message = ""
        started = time.perf_counter()
        backend = None
        finished = False
        try:
            backend = self._backend()
            drive(backend, self._tasks(), done, progress.lost)
            finished = True
        except KeyboardInterrupt:
            status = 130
        except VariantError as exc:
            status = 2
            message = f"{args.scene}: {exc}"
        except ReportProblem as exc:
            status = 2
            message = str(exc)
        except _BackendProblem as exc:
            status = 2
            message = str(exc)
        finally:
            progress.close()
            if backend is not None:   # an interruption or a bug stops the running jobs
                backend.close(abort=not finished)
        complete = len(self.records) == total
        report = assemble(self.header, self.records.values(), complete=complete)
        report["seconds"] = round(time.perf_counter() - started, 3)
        if journal is not None:
            journal.close()
            try:
                write_report(report_path, report, inputs=self.inputs)
            except ReportProblem as exc:
                return fail_usage(str(exc))
            if complete:
                journal.remove()
        if status == 130:
            where = f"; {report_path} keeps them: continue with --resume {report_path}" \
                if report_path else " (no --report: they are not kept)"
            print(f"rapidc: interrupted after {len(self.records)} of {total} runs{where}",
                  file=sys.stderr)
            return 130
        if status is not None:
            return fail_usage(message)
        # the --html page may fail to be written
        problem = print_report(report, args, page_inputs(args, self.inputs))
        if problem is not None:
            return problem
        return _status(report, args.min_success)

    def _backend(self) -> Any:
        from rapid_dsl.runtime.verification.backends import (
            InlineBackend,
            PoolBackend,
            local_threads,
        )

        args = self.args
        if args.cluster is not None:
            from rapid_dsl.runtime.verification.cluster import (
                ClusterError,
                DaskBackend,
            )

            try:
                return DaskBackend(self.job, args.cluster, self.gl_backend)
            except ClusterError as exc:
                raise _BackendProblem(str(exc)) from None
        jobs = args.jobs or 1
        if jobs == 1:
            return InlineBackend(self.job, local_threads(1))
        return PoolBackend(self.job, jobs, local_threads(jobs), self.gl_backend)

    def _tasks(self) -> Iterator[tuple[int | None, Any]]:
        """The runs still to do: the scene, then the variants, each drawn as it is handed out."""
        if None not in self.records:
            yield None, self.scene
        for index in range(self.args.variants):
            if index in self.records:
                continue
            variant = self.sampler.sample(self.args.seed, index)
            self.parameters[index] = variant.describe()
            yield index, variant.scene


def _same_file(a: Path | None, b: Path) -> bool:
    try:
        return a is not None and os.path.samefile(a, b)
    except OSError:
        return False


class _BackendProblem(Exception):
    """The cluster cannot be used (the message says why)."""


def _status(report: dict[str, Any], min_success: float) -> int:
    rate = report["summary"]["success_rate"]
    if rate is None:
        print("rapidc: every run was rejected by the program's filters: nothing was verified",
              file=sys.stderr)
        return 1
    return 0 if rate >= min_success - 1e-12 else 1
