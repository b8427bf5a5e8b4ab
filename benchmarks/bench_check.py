"""Front-end speed: lines/s on a generated 2,000-line program, the standard library, a warm
200-line strategy file (target < 50 ms) and `rapidc check` start-up (target < 300 ms).

Usage: python benchmarks/bench_check.py [--lines N] [--runs N] [--json]
(the same as `rapidc bench check`, which the package installs).
"""

from __future__ import annotations

import sys

from rapid_dsl.cli import main

if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--json"]
    output = ["--format", "json"] if "--json" in sys.argv[1:] else []
    sys.exit(main(["bench", "check", *output, *args]))
