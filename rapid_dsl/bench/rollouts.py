"""`rapidc bench rollouts`: the executor's CEM throughput against the machine's limit.

For each robot, examples/push_box.rapid runs on its push scene exactly as `rapidc run` runs it.
The headline rate is the physics steps its CEM simulates divided by the CEM's wall time (the time
inside the optimizer: control building, rollouts, Frames decoding and cost evaluation). The limit is
the raw single-thread `mj_step(nstep=500)` rate of the scene's model (the robot holding its start
pose, the box at rest) x cores, measured in the same run, just before each CEM run. Both sides take
the best of the repeats, since other processes only ever slow a run down; medians are reported too.

The CEM steps a copy of that model at the executor's planning timestep with the sensors switched
off (they are evaluated only at the recorded frames), so the report also gives the stricter ratio
against the raw rate of that copy: the executor's sensor saving does not count in it.

The synthetic batch of `rapid_dsl.bench.throughput` (64 x 1000 smooth random pushes through
`Simulator.rollout`) is the secondary figure.
"""

from __future__ import annotations

import os
import statistics
import time
from typing import Any

from rapid_dsl.bench import write_results

ROBOT_SCENES = {"floating_gripper": "push_box.yaml", "franka": "push_box_franka.yaml"}
PROGRAM = "push_box.rapid"
TARGET_RATIO = 0.75


def measure_robot(robot: str, *, repeats: int = 5, seed: int = 0, synthetic: bool = True,
                  samples: int | None = None, iterations: int | None = None) -> dict[str, Any]:
    """The CEM and raw rates of one robot (see the module doc); samples/iterations override the
    program's budget (for quick checks)."""
    from rapid_dsl.bench.examples import load_example
    from rapid_dsl.bench.throughput import bench_rollouts, raw_step_rate
    from rapid_dsl.runtime.executor import RunConfig
    from rapid_dsl.runtime.simulate import stepping_model

    if robot not in ROBOT_SCENES:
        raise ValueError(f"unknown robot `{robot}`; known: {', '.join(ROBOT_SCENES)}")
    example = load_example(PROGRAM, ROBOT_SCENES[robot])
    cores = os.cpu_count() or 2
    raws: list[float] = []
    runs: list[dict[str, Any]] = []
    stepped = stepping_model(example.world, RunConfig().planning_dt)
    stepped_raws: list[float] = []
    for _ in range(repeats):
        raws.append(raw_step_rate(example.world, repeats=5))
        stepped_raws.append(raw_step_rate(example.world, model=stepped, repeats=5))
        started = time.perf_counter()
        result = example.run(seed=seed, samples=samples, iterations=iterations)
        wall = time.perf_counter() - started
        steps = sum(p.physics_steps for p in result.phases)
        cem = sum(p.seconds.get("optimize", 0.0) for p in result.phases)
        runs.append({"steps": steps, "cem_seconds": cem, "rate": steps / cem if cem else 0.0,
                     "planning_dt": result.phases[0].planning_dt,
                     "rollouts": sum(p.rollouts for p in result.phases),
                     "run_seconds": wall, "succeeded": result.succeeded})
    best = max(runs, key=lambda r: r["rate"])
    raw = max(raws)
    limit = raw * cores
    out: dict[str, Any] = {
        "robot": robot,
        "program": PROGRAM,
        "scene": ROBOT_SCENES[robot],
        "seed": seed,
        "cores": cores,
        "repeats": repeats,
        "raw_steps_per_s": raw,
        "limit_steps_per_s": limit,
        "cem_steps": best["steps"],
        "cem_rollouts": best["rollouts"],
        "cem_seconds": best["cem_seconds"],
        "cem_steps_per_s": best["rate"],
        "planning_dt": best["planning_dt"],
        "world_dt": example.world.dt,
        "ratio": best["rate"] / limit,
        "ratio_median": statistics.median(r["rate"] for r in runs)
        / (statistics.median(raws) * cores),
        "target_ratio": TARGET_RATIO,
        "stepped_raw_steps_per_s": max(stepped_raws),
        "ratio_to_stepped": best["rate"] / (max(stepped_raws) * cores),
        "succeeded": all(r["succeeded"] for r in runs),
        "runs": runs,
        "raw_runs": raws,
        "stepped_raw_runs": stepped_raws,
    }
    if synthetic:
        batch = bench_rollouts(robot, repeats=max(3, repeats))
        out["synthetic_ratio"] = batch["ratio"]
        out["synthetic_steps_per_s"] = batch["rollout_steps_per_s"]
        out["synthetic_limit_steps_per_s"] = batch["limit_steps_per_s"]
    return out


def report(results: list[dict[str, Any]]) -> str:
    r0 = results[0]
    lines = [(f"CEM of examples/{PROGRAM} (seed {r0['seed']}), best of {r0['repeats']} runs, "
              f"rollouts at {r0['planning_dt'] * 1e3:g} ms; limit = raw 1-thread mj_step of the "
              f"scene at rest ({r0['world_dt'] * 1e3:g} ms) x {r0['cores']} cores, same run"),
             (f"{'robot':<17} {'raw 1-thread':>12} {'limit':>9} {'CEM steps':>10} {'CEM wall':>9} "
              f"{'CEM rate':>9} {'ratio':>6} {'median':>6}  target        {'strict':>6}")]
    for r in results:
        verdict = "ok" if r["ratio"] >= r["target_ratio"] else "MISSED"
        lines.append(
            f"{r['robot']:<17} {_k(r['raw_steps_per_s']):>12} {_k(r['limit_steps_per_s']):>9} "
            f"{r['cem_steps']:>10,} {r['cem_seconds']:>8.2f}s {_k(r['cem_steps_per_s']):>9} "
            f"{r['ratio']:>6.2f} {r['ratio_median']:>6.2f}  >= {r['target_ratio']:.2f} "
            f"{verdict:<6} {r['ratio_to_stepped']:>6.2f}"
            + ("" if r["succeeded"] else "  (a run FAILED)"))
    lines.append("strict = the same CEM rate against the raw rate of the copy the CEM steps "
                 "(planning timestep, sensors off): "
                 + ", ".join(f"{r['robot']} {_k(r['stepped_raw_steps_per_s'])} 1-thread"
                             for r in results))
    if all("synthetic_ratio" in r for r in results):
        lines.append("secondary, synthetic batch (64 x 1000 random pushes, Simulator.rollout): "
                     + ", ".join(f"{r['robot']} {_k(r['synthetic_steps_per_s'])} = "
                                 f"{r['synthetic_ratio']:.2f}" for r in results))
    return "\n".join(lines)


def main(*, robots: list[str] | None = None, repeats: int = 5, seed: int = 0,
         synthetic: bool = True, json_path: str | None = None) -> int:
    results = [measure_robot(robot, repeats=repeats, seed=seed, synthetic=synthetic)
               for robot in robots or list(ROBOT_SCENES)]
    print(report(results))
    if json_path:
        return write_results(json_path, results)
    return 0


def _k(rate: float) -> str:
    return f"{rate / 1e3:.1f}k"
