"""`rapidc bench nonprehensile`: the eight-task benchmark, run and tabulated as in the paper.

Each task's strategy is checked and compiled once here (the front end); the runs go to a backend
of runtime/verification/backends.py (this process, `--jobs J` worker processes, or a Dask cluster)
as `rapidc verify`'s do, each a `Trial` of rapid_dsl/bench/nonprehensile/job.py run by
rapid_dsl/bench/nonprehensile/harness.py. Test scenes (rapid_dsl/bench/nonprehensile/scenes.py) are
drawn as runs are handed out and written to OUT/scenes/ first, so any run replays with `rapidc run`.
Every finished run is appended to OUT/results.json.journal (fsynced); OUT/results.json is written at
the end or on Ctrl-C, and `--resume` keeps the runs of an earlier run with the same settings.
The table and the progress display are in rapid_dsl/bench/nonprehensile/table.py;
docs/benchmark.md describes the tasks, the scenes, the seeds and the files.
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rapid_dsl import __version__
from rapid_dsl.bench.nonprehensile.table import Progress, table, table_lines
from rapid_dsl.commands.common import fail_usage, shown

RESULTS = "results.json"
CONTROL_PROGRAM = "control.rapid"
Record = dict[str, Any]


class BenchError(Exception):
    """Bad input or an unusable setting (the message says which); exit status 2."""


@dataclass
class Settings:
    tasks: list[str]
    scenes: int
    trials: int
    out: Path
    robot: str | None = None
    jobs: int | None = None
    cluster: str | None = None
    resume: bool = False
    json_path: str | None = None
    samples: int | None = None
    iterations: int | None = None
    quiet: bool = False
    color: bool = False
    as_json: bool = False           # --format json: the results on stdout instead of the table


@dataclass
class Bench:
    settings: Settings
    tasks: dict[str, Any]                   # key -> Task
    job: Any                                # BenchJob
    header: Record
    inputs: list[str] = field(default_factory=list)        # files no output may replace
    records: dict[str, Record] = field(default_factory=dict)
    resumed_journal: Path | None = None      # the journal --resume read, appended to
    scenes: dict[tuple[str, int], Record] = field(default_factory=dict)
    trials: dict[str, Any] = field(default_factory=dict)   # key -> Trial, while it runs


def prepare(settings: Settings) -> Bench:
    """Check every input and compile every program; raises BenchError."""
    from rapid_dsl.api.compilation import ProgramError, compile_file
    from rapid_dsl.bench.nonprehensile import tasks as registry
    from rapid_dsl.bench.nonprehensile.job import FORMAT, BenchJob
    from rapid_dsl.bench.nonprehensile.scenes import TEST_SEED
    from rapid_dsl.bench.nonprehensile.spec import TASKS_DIR
    from rapid_dsl.runtime.verification.job import digest
    from rapid_dsl.runtime.verification.report import ReportProblem, check_output

    out = settings.out
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise BenchError(f"--out {out}: not a folder")
    if settings.json_path is not None:
        try:   # refused before anything runs, not after hours of it
            check_output(settings.json_path)
        except ReportProblem as exc:
            raise BenchError(f"--json: {exc}") from None
    found = {}
    for key in settings.tasks:
        try:
            found[key.upper()] = registry.task(key)
        except registry.MissingTask as exc:
            raise BenchError(f"--tasks: {exc}") from None
    strategies = {}
    for key, task in found.items():
        try:
            strategies[key], _ = compile_file(str(task.strategy_path))
        except ProgramError as exc:
            raise BenchError(f"task {key}'s strategy: {exc}") from None
    try:
        control, _ = compile_file(str(TASKS_DIR / CONTROL_PROGRAM))
    except ProgramError as exc:
        raise BenchError(f"the control: {exc}") from None
    run = {k: v for k, v in (("samples", settings.samples), ("iterations", settings.iterations))
           if v is not None}
    job = BenchJob(strategies, control, {k: registry.MODULES[k] for k in found}, run)
    options = {"tasks": list(found), "scenes": settings.scenes, "trials": settings.trials,
               "robot": settings.robot or "franka", "samples": settings.samples,
               "iterations": settings.iterations, "test_seed": TEST_SEED}
    header = {"format": FORMAT, "rapidc": __version__, "settings": options,
              "fingerprint": digest({"job": job.digest(), **options})}
    inputs = [str(TASKS_DIR / CONTROL_PROGRAM),
              *(str(p) for task in found.values() for p in (task.strategy_path, task.demo_path))]
    bench = Bench(settings, found, job, header, inputs)
    if settings.resume:
        bench.records, bench.resumed_journal = _previous(settings.out / RESULTS, header)
    return bench


def _previous(path: Path, header: Record) -> tuple[dict[str, Record], Path | None]:
    """The runs an earlier run kept, from its journal (returned too: it is appended to) or, when
    there is none, its results file. Every record is checked first
    (rapid_dsl/bench/nonprehensile/records.py): a bad one stops the command, and the journal is left
    as it was."""
    from rapid_dsl.bench.nonprehensile.records import BenchHeader, BenchRecord
    from rapid_dsl.runtime.verification.report import ReportProblem, journal_path, read_journal

    journal: Path | None = journal_path(path)
    try:
        if journal is not None and journal.exists():
            before, records = read_journal(journal, BenchHeader, BenchRecord)
        elif path.exists():
            journal = None
            before, records = _results_file(path)
        else:
            raise BenchError(f"--resume: {path.parent} holds no earlier run ({path.name} or its "
                             "journal)")
    except ReportProblem as exc:
        raise BenchError(f"--resume: {exc}") from None
    if before["fingerprint"] != header["fingerprint"]:
        raise BenchError(f"--resume {path}: it was run with other tasks, programs or settings; "
                         "run again without --resume (or with the same options)")
    return {r["key"]: r for r in records if r["outcome"] != "error"}, journal


def _results_file(path: Path) -> tuple[Record, list[Record]]:
    """The header and runs of a results file (no journal: the run finished or its journal
    went). Raises ReportProblem."""
    from rapid_dsl.bench.nonprehensile.job import FORMAT
    from rapid_dsl.bench.nonprehensile.records import BenchResults
    from rapid_dsl.language.files import FileProblem, read_text
    from rapid_dsl.language.safe_json import JsonError, loads, validate
    from rapid_dsl.runtime.verification.report import MAX_REPORT_BYTES, ReportProblem

    try:
        text = read_text(path, limit=MAX_REPORT_BYTES)
        data = loads(text, str(path))
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise ReportProblem(f"{path} is not a results file ({FORMAT})")
        validate(BenchResults, data, str(path), text=text)
    except FileProblem as exc:
        raise ReportProblem(f"{path}: {exc}") from None
    except JsonError as exc:
        raise ReportProblem(exc.first()) from None
    records = [r for scene in data["scenes"] for r in [*scene["trials"], scene["control"]]
               if r is not None]
    return data, records


def run(bench: Bench) -> int:
    """Run what is left, journal it, write the results and print the table; the exit status."""
    from rapid_dsl.language.files import FileProblem, output_folder
    from rapid_dsl.runtime.verification.report import Journal, ReportProblem, journal_path

    settings = bench.settings
    path = settings.out / RESULTS
    try:   # OUT/scenes/ is opened first: a symbolic link there is refused before anything runs
        with output_folder(settings.out, inputs=bench.inputs) as out:
            scenes = out.folder("scenes")
    except FileProblem as exc:
        raise BenchError(f"--out {settings.out}: {exc}") from None
    try:
        journal = Journal(journal_path(path), bench.header, bench.records.values(),
                          inputs=bench.inputs, append=bench.resumed_journal is not None)
    except ReportProblem as exc:
        scenes.close()
        raise BenchError(f"--out {settings.out}: {exc}") from None
    with scenes:
        return _run(bench, scenes, journal)


def _run(bench: Bench, scenes: Any, journal: Any) -> int:
    """`run` once OUT/scenes (an OutputFolder) and the journal are open."""
    from rapid_dsl.bench.nonprehensile.harness import lost_record
    from rapid_dsl.bench.nonprehensile.scenes import SceneDrawError
    from rapid_dsl.language.files import FileProblem
    from rapid_dsl.runtime.verification.backends import drive
    from rapid_dsl.runtime.verification.report import ReportProblem

    settings = bench.settings
    path = settings.out / RESULTS
    total = len(bench.tasks) * settings.scenes * (settings.trials + 1)
    progress = Progress(total, len(bench.records), quiet=settings.quiet, color=settings.color)

    def done(key: str, record: Record, timing: dict[str, float], attempts: int) -> None:
        trial = bench.trials.pop(key)
        full = {**record, "key": key, "task": trial.task, "scene": trial.scene_index,
                "trial": trial.trial, "seed": trial.seed, "scene_file": trial.scene_file,
                "execution": {"attempts": attempts, **timing}}
        bench.records[key] = full
        journal.append(full)
        progress.update(full)

    started = time.perf_counter()
    status, message, backend, finished = None, "", None, False
    try:
        backend = _backend(bench)
        drive(backend, _trials(bench, scenes), done, progress.lost, lost_record=lost_record)
        finished = True
    except KeyboardInterrupt:
        status = 130
    except (SceneDrawError, FileProblem, ReportProblem, BenchError) as exc:
        status, message = 2, str(exc)
    finally:
        progress.close()
        if backend is not None:
            backend.close(abort=not finished)
        journal.close()
    complete = len(bench.records) == total
    results = assemble(bench, complete=complete, seconds=time.perf_counter() - started)
    problem = _write(results, path, settings.json_path, bench.inputs)
    if complete and problem is None:
        journal.remove()
    if status == 130:
        print(shown(f"rapidc: interrupted after {len(bench.records)} of {total} runs; {path} "
                    f"keeps them: continue with --resume --out {settings.out}", None),
              file=sys.stderr)
        return 130
    if status is not None:
        return fail_usage(message)
    if problem is not None:
        return fail_usage(problem)
    if settings.as_json:
        import json

        print(json.dumps(results, indent=1))
    else:
        print("\n".join(table_lines(results)))
    return 0


def _backend(bench: Bench) -> Any:
    from rapid_dsl.runtime.verification.backends import InlineBackend, PoolBackend, local_threads

    settings = bench.settings
    if settings.cluster is not None:
        from rapid_dsl.runtime.verification.cluster import ClusterError, DaskBackend

        try:
            return DaskBackend(bench.job, settings.cluster, None)
        except ClusterError as exc:
            raise BenchError(str(exc)) from None
    jobs = settings.jobs or 1
    if jobs == 1:
        return InlineBackend(bench.job, local_threads(1))
    return PoolBackend(bench.job, jobs, local_threads(jobs), None)


def _trials(bench: Bench, folder: Any) -> Iterator[tuple[str, Any]]:
    """The runs still to do, task by task and scene by scene; each scene is drawn and written
    into `folder` (OUT/scenes, an OutputFolder) as its first run is handed out (and on --resume
    again, to the same bytes)."""
    from rapid_dsl.bench.nonprehensile.job import Trial, run_key, run_seed
    from rapid_dsl.bench.nonprehensile.scenes import (
        TEST_SEED,
        sample_test_scene,
        scene_name,
        task_seed,
        write_scene,
    )

    settings = bench.settings
    for key, task in bench.tasks.items():
        seed = task_seed(task)
        for index in range(settings.scenes):
            drawn = sample_test_scene(task, seed, index, settings.robot)
            name = scene_name(task, index)
            scene = write_scene(drawn.scene, folder, name)
            path = folder.path / name
            bench.scenes[(key, index)] = {"task": key, "index": index, "seed": seed,
                                          "scene_file": str(path), **drawn.describe()}
            for trial in [*range(settings.trials), None]:
                name = run_key(key, index, trial)
                if name in bench.records:
                    continue
                item = Trial(key, index, trial, run_seed(TEST_SEED, index, trial), scene,
                             str(path))
                bench.trials[name] = item
                yield name, item


def _write(results: Record, path: Path, json_path: str | None, inputs: list[str]) -> str | None:
    from rapid_dsl.runtime.verification.report import ReportProblem, write_report

    try:
        write_report(path, results, inputs=inputs)
        if json_path is not None:
            write_report(json_path, results, inputs=inputs)
    except ReportProblem as exc:
        return str(exc)
    return None


# ------------------------------------------------------------------------------ results

def assemble(bench: Bench, *, complete: bool, seconds: float) -> Record:
    """The results file: settings, commit, machine, the table, and per scene its runs."""
    settings = bench.settings
    scenes = []
    for key in bench.tasks:
        for index in range(settings.scenes):
            runs = [bench.records.get(_key(key, index, t)) for t in range(settings.trials)]
            control = bench.records.get(_key(key, index, None))
            if not any(runs) and control is None:
                continue
            first = next((r for r in runs if r), control or {})
            described = bench.scenes.get((key, index)) or \
                {"task": key, "index": index, "scene_file": first.get("scene_file")}
            scenes.append({**described, "binding": first.get("binding"),
                           "binding_note": first.get("binding_note"),
                           "trials": [r for r in runs if r], "control": control})
    return {**bench.header, "complete": complete, "seconds": round(seconds, 3),
            "commit": _commit(), "machine": {"cpus": os.cpu_count(),
                                             "platform": platform.platform(),
                                             "python": platform.python_version()},
            "table": table(bench.records, bench.tasks, settings.scenes, settings.trials),
            "scenes": scenes}


def _key(task: str, scene: int, trial: int | None) -> str:
    from rapid_dsl.bench.nonprehensile.job import run_key

    return run_key(task, scene, trial)


def _commit() -> str | None:
    """`git describe` of the source tree, when it is a git checkout and git is there."""
    try:
        done = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"],
                              cwd=Path(__file__).resolve().parent, capture_output=True,
                              text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() or None if done.returncode == 0 else None


def main(settings: Settings) -> int:
    try:
        bench = prepare(settings)
        return run(bench)
    except BenchError as exc:
        return fail_usage(str(exc))
