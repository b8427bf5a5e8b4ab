"""What the front end hands the runtime: a checked program's generated module and its entry.

Plain text, light to import (no numpy or mujoco), so it pickles to worker processes and cluster
workers; wherever it arrives, the loader (runtime/loader.py) verifies the module before it runs.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class CompiledProgram:
    source: str        # the generated module (rapidc compile prints the same text)
    name: str          # module stem, for `<rapid NAME>` in tracebacks and load errors
    entry: str         # the primitive or strategy to run
    path: str          # the program file, as the user named it
