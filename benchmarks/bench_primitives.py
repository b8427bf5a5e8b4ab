"""CEM wall time, rollouts, steps/s and success of each stdlib primitive on its demo scene.

Usage: python benchmarks/bench_primitives.py [--primitive NAME] [--seeds 0 1 2] [--repeats N]
[--json OUT.json] (the same as `rapidc bench primitives`, which the package installs).
"""

from __future__ import annotations

import sys

from rapid_dsl.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "primitives", *sys.argv[1:]]))
