"""`rapidc bench primitives`: the CEM wall time of each stdlib primitive on its demo scene.

Each primitive runs, at its default budget, as a phase of its example program on the example's
scene, exactly as `rapidc run` runs it (pick_and_place gives grasp, lift and move in one run). Per
primitive and seed the benchmark takes the best of the repeats (other processes only slow a run
down) and reports the CEM wall time (inside the optimizer), rollouts, physics steps, steps/s, the
phase's own success and the example's; the table shows the slowest seed against the target.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rapid_dsl.bench import write_results

TARGET_SECONDS = 3.0


class UnknownPrimitive(ValueError):
    """--primitive names a primitive that has no demo here (a usage error)."""


@dataclass(frozen=True)
class Demo:
    primitive: str
    program: str
    scene: str
    phase: str


DEMOS = (
    Demo("push", "push_box.rapid", "push_box.yaml", "shove"),
    Demo("press_move", "press_book.rapid", "press_book.yaml", "slide"),
    Demo("flip", "flip_box.rapid", "flip_box.yaml", "tip"),
    Demo("pivot", "pivot_bar.rapid", "pivot_bar.yaml", "turn"),
    Demo("topple", "topple_carton.rapid", "topple_box.yaml", "tip"),
    Demo("grasp", "pick_and_place.rapid", "grasp_block.yaml", "take"),
    Demo("lift", "pick_and_place.rapid", "grasp_block.yaml", "raise"),
    Demo("move", "pick_and_place.rapid", "grasp_block.yaml", "carry"),
    Demo("reach", "hop_over.rapid", "push_box.yaml", "over"),
    Demo("retreat", "hop_over.rapid", "push_box.yaml", "leave"),
    Demo("release", "place_block.rapid", "grasp_block.yaml", "let_go"),
)


def measure(*, primitives: list[str] | None = None, seeds: tuple[int, ...] = (0,),
            repeats: int = 1, samples: int | None = None,
            iterations: int | None = None) -> list[dict[str, Any]]:
    """One row per primitive, with per-seed details (see the module doc); samples/iterations
    override the default budgets (for quick checks)."""
    from rapid_dsl.bench.examples import load_example

    chosen = [d for d in DEMOS if primitives is None or d.primitive in primitives]
    unknown = set(primitives or ()) - {d.primitive for d in DEMOS}
    if unknown:
        raise UnknownPrimitive(f"unknown primitive(s) {', '.join(sorted(unknown))}; known: "
                         f"{', '.join(d.primitive for d in DEMOS)}")
    runs: dict[tuple[str, int], list[Any]] = {}   # (program, seed) -> RunResults
    for key in dict.fromkeys((d.program, d.scene) for d in chosen):
        example = load_example(*key)
        for seed in seeds:
            runs[(key[0], seed)] = [example.run(seed=seed, samples=samples, iterations=iterations)
                                     for _ in range(repeats)]
    rows = []
    for demo in chosen:
        per_seed = []
        for seed in seeds:
            phases = [(result, next(p for p in result.phases if p.name == demo.phase))
                      for result in runs[(demo.program, seed)]]
            result, phase = min(phases, key=lambda rp: rp[1].seconds.get("optimize", 1e9))
            cem = phase.seconds.get("optimize", float("nan"))
            per_seed.append({
                "seed": seed, "cem_seconds": cem, "phase_seconds": phase.seconds.get("total"),
                "rollouts": phase.rollouts, "steps": phase.physics_steps,
                "planning_dt": phase.planning_dt,
                "steps_per_s": phase.physics_steps / cem if cem else 0.0,
                "samples": phase.samples, "iterations": phase.iterations,
                "succeeded": phase.succeeded, "failure": phase.failure,
                "example_succeeded": result.succeeded,
            })
        worst = max(per_seed, key=lambda s: s["cem_seconds"])
        rows.append({"primitive": demo.primitive, "program": demo.program, "scene": demo.scene,
                     "phase": demo.phase, "target_seconds": TARGET_SECONDS,
                     "cem_seconds_max": worst["cem_seconds"], "seeds": per_seed})
    return rows


def report(rows: list[dict[str, Any]], repeats: int) -> str:
    seeds = ", ".join(str(s["seed"]) for s in rows[0]["seeds"]) if rows else ""
    lines = [(f"CEM per stdlib primitive, default budgets; slowest of seeds {seeds}, each the best "
             f"of {repeats} run(s)"),
             (f"{'primitive':<11} {'demo phase':<27} {'budget':>7} {'rollouts':>8} {'steps':>9} "
             f"{'CEM wall':>9} {'steps/s':>8}  {'success':>7} {'example':>7}  target")]
    for row in rows:
        s = max(row["seeds"], key=lambda x: x["cem_seconds"])
        n = len(row["seeds"])
        ok = sum(x["succeeded"] for x in row["seeds"])
        ex = sum(x["example_succeeded"] for x in row["seeds"])
        verdict = "ok" if row["cem_seconds_max"] < row["target_seconds"] else "MISSED"
        lines.append(
            f"{row['primitive']:<11} {row['program'][:-6] + ':' + row['phase']:<27} "
            f"{str(s['samples']) + 'x' + str(s['iterations']):>7} {s['rollouts']:>8} "
            f"{s['steps']:>9,} {s['cem_seconds']:>8.2f}s {s['steps_per_s'] / 1e3:>7.1f}k  "
            f"{ok:>5}/{n} {ex:>5}/{n}  < {row['target_seconds']:.0f} s {verdict}")
    return "\n".join(lines)


def main(*, primitives: list[str] | None = None, seeds: tuple[int, ...] = (0,), repeats: int = 1,
         json_path: str | None = None) -> int:
    rows = measure(primitives=primitives, seeds=seeds, repeats=repeats)
    print(report(rows, repeats))
    if json_path:
        return write_results(json_path, rows)
    return 0
