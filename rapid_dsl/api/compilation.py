"""Programs checked and compiled for the runtime: the front-end half of a run session.

`rapidc run`, `rapidc verify` and the benchmarks check a program (commands/building.py prints
its diagnostics), then hand it to the runtime as a `rapid_dsl.runtime.compiled.CompiledProgram`:
the generated module and the entry to run. The runtime half (runtime/session.py) loads it, builds
worlds and executes. `clause_locations` keeps what the runtime's clause origins (`FILE:LINE`)
leave out: each clause's full source span, for reports that point at `file:line:column`.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from pathlib import Path

from rapid_dsl.frontend import ir
from rapid_dsl.runtime.compiled import CompiledProgram
from rapid_dsl.runtime.verification.records import location_key


class ProgramError(Exception):
    """The program cannot be read or does not check clean (the message says why)."""


def compile_checked(program: ir.Program, path: str, entry: str) -> CompiledProgram:
    """Compile a checked program (entry chosen with choose_entry)."""
    from rapid_dsl.compiler import compile_program

    return CompiledProgram(compile_program(program).source, module_stem(path), entry, path)


def compile_file(path: str, *, entry: str | None = None,
                 allowed_dirs: Sequence[str | os.PathLike[str]] = ()
                 ) -> tuple[CompiledProgram, ir.Program]:
    """Check and compile the program in `path` without printing (for benchmarks and tools).
    Raises ProgramError for an unreadable file, an error diagnostic or no runnable entry."""
    from rapid_dsl.frontend.driver import InputError, check_file

    try:
        checked = check_file(path, allowed_dirs=allowed_dirs)
    except InputError as exc:
        raise ProgramError(exc.message) from None
    errors = [d for d in checked.diagnostics if d.is_error]
    if checked.program is None or errors:
        first = errors[0] if errors else None
        where = f"{first.span.path}:{first.span.line}:{first.span.col}: " if first else ""
        raise ProgramError(f"{path} does not check: {where}{first.message if first else ''}")
    try:
        chosen = choose_entry(checked.program, entry)
    except ValueError as exc:
        raise ProgramError(str(exc)) from None
    return compile_checked(checked.program, path, chosen), checked.program


def clause_locations(program: ir.Program) -> dict[str, dict[str, object]]:
    """Every requires, success and filter clause, keyed by `location_key(origin, text)`, with its
    span: {"file", "line", "col", "end_line", "end_col"} (the file as diagnostics name it)."""
    from rapid_dsl.compiler.sources import SourceFiles

    files = SourceFiles(program.path)
    spans: dict[str, dict[str, object]] = {}
    for clause in _clauses(program):
        span = clause.span
        key = location_key(files.origin(span), clause.text)
        spans.setdefault(key, {"file": span.path, "line": span.line, "col": span.col,
                               "end_line": span.end_line, "end_col": span.end_col})
    return spans


def _clauses(program: ir.Program) -> Iterator[ir.Clause]:
    for primitive in program.primitives:
        yield from (*primitive.requires, *primitive.success, *primitive.filter)
    for strategy in program.strategies:
        yield from (*strategy.requires, *strategy.success, *strategy.filter)
        for phase in strategy.phases:
            yield from phase.unchecked_requires


def module_stem(path: str) -> str:
    """`lib/push_box.rapid` -> `push_box`; the YAML form's `x.rapid.yaml` -> `x`."""
    name = Path(path).name
    for suffix in (".rapid.yaml", ".rapid.yml", ".rapid", ".yaml", ".yml"):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    return Path(name).stem


def choose_entry(program: ir.Program, wanted: str | None) -> str:
    """The declaration `rapidc run` runs (LANGUAGE.md section 6). Raises ValueError."""
    primitives = {p.name for p in program.primitives}
    strategies = {s.name for s in program.strategies}
    own_strategies = [n for n in program.own if n in strategies]
    own_primitives = [n for n in program.own if n in primitives]
    if wanted is not None:
        if wanted in strategies or wanted in primitives:
            return wanted
        runnable = ", ".join(sorted(strategies | primitives)) or "none"
        raise ValueError(f"--entry {wanted}: no primitive or strategy of that name; runnable "
                         f"declarations: {runnable}")
    if len(own_strategies) == 1:
        return own_strategies[0]
    if len(own_strategies) > 1:
        raise ValueError(f"{program.path} declares several strategies "
                         f"({', '.join(own_strategies)}); choose one with --entry NAME")
    if len(own_primitives) == 1:
        return own_primitives[0]
    if own_primitives:
        raise ValueError(f"{program.path} declares several primitives "
                         f"({', '.join(own_primitives)}) and no strategy; choose one with "
                         "--entry NAME")
    brought = ", ".join(sorted(strategies | primitives))
    if brought:
        raise ValueError(f"{program.path} declares no primitive or strategy of its own; choose "
                         f"one it brings in with --entry NAME ({brought})")
    raise ValueError(f"{program.path} has nothing to run: it declares no primitive or strategy")
