"""`rapidc bench verify`: verification throughput (variants per minute) with 1 and 2 jobs.

Runs one example program on the same seeded variants of its scene twice in one run, in a pool of
1 and then 2 worker processes (runtime/verification/backends.py, as `rapidc verify --jobs J` uses
it), each job simulating on one thread so the pool alone makes the difference. Each pool is started
and its workers load the program before the clock starts (that start-up is reported apart); variants
are drawn beforehand. The CPU time of the jobs over the wall time says how many cores the pool got:
on a machine that other work shares, 2 jobs get fewer than 2. With repeats, the two pool
sizes take turns and each keeps its best run (other processes only ever slow a run down).
Reports variants per minute, the success rate, the speed-up (target: 2 jobs >= 1.8x 1 job on a
2-core machine), whether every run gave the same results, and the load average.
"""

from __future__ import annotations

import json
import os
import time
from typing import Any

from rapid_dsl.bench import write_results

PROGRAM = "push_box.rapid"
SCENE = "push_box.yaml"
TARGET_SPEEDUP = 1.8
JOBS = (1, 2)


def measure(*, program: str = PROGRAM, scene: str = SCENE, variants: int = 8, seed: int = 0,
            samples: int | None = None, iterations: int | None = None,
            repeats: int = 1) -> dict[str, Any]:
    """Both pool sizes on the same variants (see the module doc)."""
    from rapid_dsl.api.compilation import ProgramError, clause_locations, compile_file
    from rapid_dsl.bench.examples import EXAMPLES, SCENES, ExampleError
    from rapid_dsl.runtime.scenes.scene import load_scene
    from rapid_dsl.runtime.variants.sampler import VariantSampler
    from rapid_dsl.runtime.verification.job import VerifyJob

    try:
        compiled, checked = compile_file(str(EXAMPLES / program))
    except ProgramError as exc:
        raise ExampleError(str(exc)) from None
    base = load_scene(SCENES / scene)
    sampler = VariantSampler(base)
    tasks = [(i, sampler.sample(seed, i).scene) for i in range(variants)]
    job = VerifyJob(compiled, {"seed": None, "samples": samples, "iterations": iterations},
                    locations=clause_locations(checked))
    load = os.getloadavg()
    measured = [[_run(job, jobs, tasks) for jobs in JOBS] for _ in range(repeats)]
    records = {json.dumps(run.pop("records"), sort_keys=True) for turn in measured
               for run in turn}
    one, two = (max((turn[i] for turn in measured), key=lambda r: r["variants_per_minute"])
                for i in range(len(JOBS)))
    return {"program": program, "scene": scene, "variants": variants, "seed": seed,
            "samples": samples, "iterations": iterations, "repeats": repeats, "runs": [one, two],
            "speedup": two["variants_per_minute"] / one["variants_per_minute"],
            "target_speedup": TARGET_SPEEDUP, "same_results": len(records) == 1,
            "load_before": list(load), "load_after": list(os.getloadavg()),
            "cpus": os.cpu_count()}


def _run(job: Any, jobs: int, tasks: list[tuple[int, Any]]) -> dict[str, Any]:
    from rapid_dsl.runtime.verification.backends import PoolBackend, drive

    records: dict[int | None, dict[str, Any]] = {}
    cpu = [0.0]

    def done(index: int | None, record: dict[str, Any], timing: dict[str, float],
             attempts: int) -> None:
        records[index] = record
        cpu[0] += timing["cpu_seconds"]

    started = time.perf_counter()
    backend = PoolBackend(job, jobs, threads=1, gl_backend=None)
    try:
        # every worker starts and loads the program before the clock starts
        drive(backend, iter([tasks[0]] * jobs), lambda *done_args: None)
        ready = time.perf_counter()
        drive(backend, iter(tasks), done)
        finished = time.perf_counter()
    finally:
        backend.close(abort=False)
    wall = finished - ready
    succeeded = sum(r["outcome"] == "succeeded" for r in records.values())
    ran = sum(r["outcome"] != "rejected" for r in records.values())
    return {"jobs": jobs, "startup_seconds": ready - started, "seconds": wall,
            "variants_per_minute": 60.0 * len(tasks) / wall,
            "cpu_seconds_per_variant": cpu[0] / len(tasks), "cores_used": cpu[0] / wall,
            "success_rate": succeeded / ran if ran else None,
            "records": [records[i] for i, _ in tasks]}


def report(result: dict[str, Any]) -> str:
    budget = "program budgets" if result["samples"] is None and result["iterations"] is None \
        else f"--samples {result['samples']} --iterations {result['iterations']}"
    lines = [f"rapidc verify throughput: examples/{result['program']} on "
             f"{result['variants']} variants of {result['scene']} (seed {result['seed']}, "
             f"{budget}), one rollout thread per job, best of {result['repeats']}",
             f"{'jobs':>4} {'start-up':>9} {'wall':>8} {'variants/min':>13} {'CPU/variant':>12} "
             f"{'cores used':>11} {'success':>8}"]
    for run in result["runs"]:
        rate = "-" if run["success_rate"] is None else f"{100 * run['success_rate']:.0f}%"
        lines.append(f"{run['jobs']:>4} {run['startup_seconds']:>8.1f}s {run['seconds']:>7.1f}s "
                     f"{run['variants_per_minute']:>13.1f} "
                     f"{run['cpu_seconds_per_variant']:>11.2f}s {run['cores_used']:>11.2f} "
                     f"{rate:>8}")
    verdict = "ok" if result["speedup"] >= result["target_speedup"] else "MISSED"
    load = ", ".join(f"{x:.2f}" for x in result["load_before"])
    lines.append(f"speed-up 2 jobs / 1 job: {result['speedup']:.2f}x (target >= "
                 f"{result['target_speedup']}x: {verdict}); same results: "
                 f"{'yes' if result['same_results'] else 'NO'}; {result['cpus']} cpus, load "
                 f"average {load} before")
    return "\n".join(lines)


def main(*, variants: int = 8, seed: int = 0, samples: int | None = None,
         iterations: int | None = None, repeats: int = 1, json_path: str | None = None) -> int:
    result = measure(variants=variants, seed=seed, samples=samples, iterations=iterations,
                     repeats=repeats)
    print(report(result))
    if json_path:
        return write_results(json_path, result)
    return 0
