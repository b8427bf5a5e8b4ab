"""Measure batched rollout throughput against the machine's limit, for both robots.

Usage: python benchmarks/bench_rollouts.py [floating_gripper|franka ...] [--json]
"""

from __future__ import annotations

import json
import os
import sys

os.environ.setdefault("OMP_NUM_THREADS", "1")  # small numpy solves must not fight the sim threads

from rapid_dsl.runtime.bench import SCENES, bench_rollouts  # noqa: E402


def main(argv: list[str]) -> int:
    as_json = "--json" in argv
    robots = [a for a in argv if not a.startswith("--")] or list(SCENES)
    results = [bench_rollouts(robot) for robot in robots]
    if as_json:
        print(json.dumps(results, indent=2))
        return 0
    for r in results:
        print(f"{r['robot']:>17}: raw {r['raw_steps_per_s'] / 1e3:6.1f}k steps/s x {r['cores']} "
              f"cores = limit {r['limit_steps_per_s'] / 1e3:6.1f}k; rollouts "
              f"{r['rollout_steps_per_s'] / 1e3:6.1f}k ({r['samples']} x {r['nstep']}, "
              f"{r['nthread']} threads) -> ratio {r['ratio']:.2f}; workload limit "
              f"{r['workload_1thread_steps_per_s'] * r['cores'] / 1e3:6.1f}k -> "
              f"{r['ratio_to_workload_limit']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
