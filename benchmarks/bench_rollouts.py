"""The executor's CEM throughput (physics steps/s) against raw mj_step x cores, for both robots;
the synthetic batch as the secondary figure.

Usage: python benchmarks/bench_rollouts.py [--robot NAME] [--repeats N] [--json OUT.json]
(the same as `rapidc bench rollouts`, which the package installs).
"""

from __future__ import annotations

import sys

from rapid_dsl.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "rollouts", *sys.argv[1:]]))
