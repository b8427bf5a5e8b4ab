"""Plan = execute: success, wall time and planned-vs-executed mismatch of every stdlib demo.

Runs each example program (default budgets, seed 0) on its demo scene's seeded variants
(runtime/variants/sampler.py, the mild ranges of tests/stdlib) under one executor design, and writes
one JSON line per run: success, outcome, wall time, and per phase the planned and executed cost and
success. A design is a planning timestep and how many of the final CEM elites are executed at the
world's timestep (docs/physics.md records the results).

Usage: python -m rapid_dsl.bench.plan_execute --design plan4 --variants 20 [--ranges default]
           --out plan4.jsonl
       python -m rapid_dsl.bench.plan_execute --summary plan4.jsonl [plan2.jsonl ...]
       python -m rapid_dsl.bench.plan_execute --timing plan4 plan4_elites plan2 --repeats 3
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

# design -> RunConfig fields: the old one (plan at 4 ms, execute the best), planning at the
# world's 2 ms, and executing the final elites at 2 ms after planning at 4 ms.
DESIGNS: dict[str, dict[str, Any]] = {
    "plan4": {"planning_dt": 0.004, "execute_elites": 1},
    "plan2": {"planning_dt": None, "execute_elites": 1},
    "plan4_elites": {"planning_dt": 0.004, "execute_elites": 0},
}
# demo program -> scene (examples/scenes); push_box also on the arm
DEMOS = [("push_box.rapid", "push_box.yaml"), ("push_box.rapid", "push_box_franka.yaml"),
         ("press_book.rapid", "press_book.yaml"), ("flip_box.rapid", "flip_box.yaml"),
         ("pivot_bar.rapid", "pivot_bar.yaml"), ("topple_carton.rapid", "topple_box.yaml"),
         ("pick_and_place.rapid", "grasp_block.yaml"), ("keep_clear.rapid", "flip_box.yaml")]
VARIANT_SEED = 11


def run_design(design: str, variants: int, out: Path, demos: list[str] | None,
               ranges: str, robot: str | None) -> None:
    from rapid_dsl.bench.examples import SCENES, load_example
    from rapid_dsl.runtime.executor import Executor, RunConfig
    from rapid_dsl.runtime.scenes.scene import load_scene, parse_scene
    from rapid_dsl.runtime.scenes.world import build_world
    from rapid_dsl.runtime.variants.sampler import VariantRanges, sample_variants

    fields = dict(DESIGNS[design])
    if "execute_elites" not in RunConfig.__dataclass_fields__:   # the old executor
        fields.pop("execute_elites")
    chosen = VariantRanges(position=0.015, yaw=math.radians(8), size=0.08, mass=0.25,
                           friction=0.15) if ranges == "mild" else VariantRanges()
    with out.open("a", encoding="utf-8") as sink:
        for program, scene in DEMOS:
            if demos and program[:-6] not in demos:
                continue
            example = load_example(program, scene)
            base = load_scene(SCENES / scene)
            if robot is not None:   # the same scene with another robot
                if base.robot == robot:
                    continue
                text = (SCENES / scene).read_text(encoding="utf-8")
                base = parse_scene(text.replace(f"robot: {base.robot}", f"robot: {robot}"),
                                   str(SCENES / scene))
                scene = f"{scene[:-5]}+{robot}.yaml"
            for variant in sample_variants(base, variants, seed=VARIANT_SEED, ranges=chosen):
                world = build_world(variant.scene)
                executor = Executor(example.loaded.program, world,
                                    config=RunConfig(seed=0, **fields),
                                    locate=example.loaded.locate)
                started = time.perf_counter()
                result = executor.run(example.loaded.program.strategies[0].name, scene=scene)
                wall = time.perf_counter() - started
                row = _row(design, program, scene, variant.index, result, wall)
                sink.write(json.dumps(row | {"ranges": ranges}) + "\n")
                sink.flush()


def timing(designs: list[str], repeats: int, demos: list[str] | None) -> str:
    """Per demo phase on the demo's own scene: the best over `repeats` of the CEM time and of
    the execution time for each design, the designs interleaved so that load hits all alike."""
    from rapid_dsl.bench.examples import load_example
    from rapid_dsl.runtime.executor import Executor, RunConfig

    best: dict[tuple[str, str], list[float]] = {}
    for program, scene in DEMOS:
        if demos and program[:-6] not in demos:
            continue
        example = load_example(program, scene)
        for _ in range(repeats):
            for design in designs:
                executor = Executor(example.loaded.program, example.world,
                                    config=RunConfig(seed=0, **DESIGNS[design]),
                                    locate=example.loaded.locate)
                result = executor.run(example.loaded.program.strategies[0].name, scene=scene)
                for p in result.phases:
                    key = (f"{program[:-6]}:{p.name}@{scene[:-5]}", design)
                    times = (p.seconds.get("optimize", 0.0), p.seconds.get("execute", 0.0))
                    old = best.get(key)
                    best[key] = list(times) if old is None or sum(times) < sum(old) else old
    lines = ["phase@scene".ljust(38) + "".join(f"{d:>22}" for d in designs),
             " " * 38 + "".join(f"{'CEM + execute [s]':>22}" for _ in designs)]
    for phase in dict.fromkeys(k[0] for k in best):
        cells = [best.get((phase, d)) for d in designs]
        lines.append(phase.ljust(38) + "".join(
            f"{c[0]:>11.2f} + {c[1]:<8.2f}" if c else f"{'-':>22}" for c in cells))
    return "\n".join(lines)


def _row(design: str, program: str, scene: str, index: int, result: Any,
         wall: float) -> dict[str, Any]:
    phases = []
    for p in result.phases:
        costs = p.best_cost_per_iteration
        phases.append({
            "name": p.name, "status": p.status,
            "planned_cost": getattr(p, "planned_cost", None) or (costs[-1] if costs else None),
            "executed_cost": getattr(p, "executed_cost", getattr(p, "final_cost", None)),
            "planned_success": getattr(p, "planned_success", None),
            "optimize_s": p.seconds.get("optimize"), "execute_s": p.seconds.get("execute"),
            "total_s": p.seconds.get("total"), "steps": p.physics_steps,
        })
    return {"design": design, "program": program, "scene": scene, "variant": index,
            "succeeded": result.succeeded, "outcome": getattr(result, "outcome", None),
            "failure": result.failure, "wall_s": wall, "phases": phases}


def summary(paths: list[Path]) -> str:
    """One column per file (named after it): success, mean wall time per run and the phases whose
    planned success differs from the executed one."""
    rows = [json.loads(line) | {"file": path.stem} for path in paths
            for line in path.read_text().splitlines() if line]
    table: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for row in rows:
        table[(f"{row['program'][:-6]}@{row['scene'][:-5]}", row["file"])].append(row)
    designs = [path.stem for path in paths]
    lines = ["demo@scene".ljust(34) + "".join(f"{d[-27:]:>28}" for d in designs),
             " " * 34 + "".join(f"{'success  wall/run  mismatch':>28}" for _ in designs)]
    totals: dict[str, list[float]] = defaultdict(lambda: [0, 0, 0.0, 0, 0])
    for demo in dict.fromkeys(k[0] for k in table):
        cells = []
        for design in designs:
            runs = table.get((demo, design), [])
            if not runs:
                cells.append(f"{'-':>28}")
                continue
            ok = sum(r["succeeded"] for r in runs)
            wall = sum(r["wall_s"] for r in runs) / len(runs)
            ran = [p for r in runs for p in r["phases"] if p["planned_success"] is not None]
            bad = sum(p["planned_success"] != (p["status"] == "succeeded") for p in ran)
            total = totals[design]
            total[0] += ok
            total[1] += len(runs)
            total[2] += wall * len(runs)
            total[3] += bad
            total[4] += len(ran)
            mismatch = f"{bad}/{len(ran)}" if ran else "-"
            cells.append(f"{ok:>9}/{len(runs):<3}{wall:>7.2f}s{mismatch:>9}")
        lines.append(demo.ljust(34) + "".join(cells))
    cells = []
    for design in designs:
        ok, n, wall, bad, ran = totals[design]
        mismatch = f"{bad}/{ran}" if ran else "-"
        cells.append(f"{ok:>9}/{n:<3}{wall / max(n, 1):>7.2f}s{mismatch:>9}")
    lines.append("all".ljust(34) + "".join(cells))
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--design", choices=sorted(DESIGNS))
    parser.add_argument("--variants", type=int, default=8)
    parser.add_argument("--demo", action="append", help="program stem(s) to run (default: all)")
    parser.add_argument("--robot", choices=("franka", "floating_gripper"),
                        help="run every demo scene with this robot instead (skips those that "
                             "have it already)")
    parser.add_argument("--ranges", choices=("mild", "default"), default="mild",
                        help="variant ranges: the mild ones of tests/stdlib or VariantRanges()")
    parser.add_argument("--out", type=Path)
    parser.add_argument("--summary", type=Path, nargs="+")
    parser.add_argument("--timing", nargs="+", choices=sorted(DESIGNS),
                        help="time these designs on the demos' own scenes instead")
    parser.add_argument("--repeats", type=int, default=3, help="--timing: runs per design")
    args = parser.parse_args()
    if args.summary:
        print(summary(args.summary))
        return 0
    if args.timing:
        print(timing(args.timing, args.repeats, args.demo))
        return 0
    if not args.design or not args.out:
        parser.error("--design and --out are required (or --summary)")
    run_design(args.design, args.variants, args.out, args.demo, args.ranges, args.robot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
