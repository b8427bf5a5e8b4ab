"""Benchmarks behind `rapidc bench TARGET`, one module per target."""

from __future__ import annotations

import json
import sys

from rapid_dsl.language.files import FileProblem, write_atomic


def write_results(path: str, results: object) -> int:
    """`--json OUT.json`: write the results atomically, never through a symlink; the exit status
    (2, reported, when the file cannot be written)."""
    try:
        write_atomic(path, json.dumps(results, indent=2) + "\n")
    except FileProblem as exc:
        print(f"rapidc: error: cannot write {path}: {exc}", file=sys.stderr)
        return 2
    return 0
