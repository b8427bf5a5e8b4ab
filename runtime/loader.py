"""Verify a generated module, run it in a namespace holding only the runtime's API, and map its
errors back to `.rapid` lines.

The module is parsed once; its syntax tree must pass `rapid_dsl.runtime.allow_list` (the shapes the
compiler emits) and is then compiled as it is. It runs with no Python builtins: its namespace's
`__import__` answers exactly the header imports of `rapid_dsl.runtime.api.IMPORTS`, with facades
that hold only the names the compiler targets. The source stays in memory under a file name of the
form `<rapid NAME>`, registered in `linecache` so that tracebacks show the generated lines.
"""

from __future__ import annotations

import ast
import linecache
from dataclasses import dataclass
from types import SimpleNamespace, TracebackType
from typing import Any

from rapid_dsl.runtime.allow_list import Refused, verify
from rapid_dsl.runtime.api import IMPORTS
from rapid_dsl.runtime.program import Program, origin_of

_ANSWERS = {(i.module, i.name): i for i in IMPORTS.values()}


class LoadError(RuntimeError):
    """The generated module is not a loadable program."""


def _import_table(name: str, globals: Any = None, locals: Any = None, fromlist: Any = (),
                  level: int = 0) -> SimpleNamespace:
    """`__import__` for a verified module: only the header imports, answered with facades."""
    names = tuple(fromlist or ())
    if level != 0 or len(names) != 1 or (name, names[0]) not in _ANSWERS:
        raise ImportError(f"a compiled program imports only the runtime's header modules, "
                          f"not `{name}`")
    return SimpleNamespace(**{names[0]: _ANSWERS[(name, names[0])].facade()})


@dataclass(frozen=True, slots=True)
class LoadedProgram:
    program: Program
    source: str
    filename: str
    sources: tuple[str, ...]        # the module's SOURCES: what its line markers index

    def locate(self, exc: BaseException) -> str | None:
        """The `.rapid` location of the innermost generated frame in exc's traceback."""
        line = _innermost_line(exc, self.filename)
        return None if line is None else origin_of(self.source, line, self.sources)


def load(source: str, name: str) -> LoadedProgram:
    """Verify and execute generated source; returns its `PROGRAM`. Raises LoadError."""
    filename = f"<rapid {name}>"
    problem = f"cannot load the compiled program {name}"
    try:
        tree = ast.parse(source, filename)
        verify(tree)
        code = compile(tree, filename, "exec")
    except SyntaxError as exc:
        raise LoadError(f"{problem}: line {exc.lineno}: {exc.msg}") from None
    except Refused as exc:
        raise LoadError(f"{problem}: {exc}") from None
    except (RecursionError, MemoryError):
        raise LoadError(f"{problem}: it is nested too deeply to compile") from None
    except ValueError as exc:      # e.g. a NUL character, on Python 3.11
        raise LoadError(f"{problem}: {exc}") from None
    linecache.cache[filename] = (len(source), None, source.splitlines(keepends=True), filename)
    namespace: dict[str, Any] = {"__builtins__": {"__import__": _import_table},
                                 "__name__": "rapid_program"}
    try:
        exec(code, namespace)  # noqa: S102 - verified; no builtins; imports answered by a table
    except Exception as exc:
        line = _innermost_line(exc, filename)
        where = f" at line {line}" if line is not None else ""
        raise LoadError(f"{problem}{where}: {type(exc).__name__}: {exc}") from None
    program = namespace.get("PROGRAM")
    if not isinstance(program, Program):
        raise LoadError(f"{problem}: it defines no PROGRAM")
    sources = namespace.get("SOURCES", ())
    if not isinstance(sources, tuple) or not all(isinstance(s, str) for s in sources):
        raise LoadError(f"{problem}: its SOURCES is not a tuple of file names")
    return LoadedProgram(program, source, filename, sources)


def _innermost_line(exc: BaseException, filename: str) -> int | None:
    """The line of the innermost frame of exc's traceback that runs generated code."""
    line = None
    tb: TracebackType | None = exc.__traceback__
    while tb is not None:
        if tb.tb_frame.f_code.co_filename == filename:
            line = tb.tb_lineno
        tb = tb.tb_next
    return line
