"""Load a generated module in a restricted namespace and map its errors back to `.rapid` lines.

The module gets no Python builtins and may import only `rapid_dsl.runtime` modules: a compiled
program can do nothing but what the runtime offers. The source stays in memory (it is not written
to disk), under a file name of the form `<rapid NAME>` that tracebacks show.
"""

from __future__ import annotations

import builtins
from dataclasses import dataclass
from types import TracebackType
from typing import Any

from rapid_dsl.runtime.program import Program, origin_of

ALLOWED_PREFIX = "rapid_dsl.runtime"


class LoadError(RuntimeError):
    """The generated module is not a loadable program."""


def _guarded_import(name: str, globals: Any = None, locals: Any = None, fromlist: Any = (),
                    level: int = 0) -> Any:
    if level != 0 or not (name == ALLOWED_PREFIX or name.startswith(ALLOWED_PREFIX + ".")):
        raise ImportError(f"a compiled program may import only {ALLOWED_PREFIX} modules, "
                          f"not `{name}`")
    return builtins.__import__(name, globals, locals, fromlist, level)


@dataclass(frozen=True, slots=True)
class LoadedProgram:
    program: Program
    source: str
    filename: str

    def locate(self, exc: BaseException) -> str | None:
        """The `.rapid` location of the innermost generated frame in exc's traceback."""
        found = None
        tb: TracebackType | None = exc.__traceback__
        while tb is not None:
            if tb.tb_frame.f_code.co_filename == self.filename:
                found = origin_of(self.source, tb.tb_lineno)
            tb = tb.tb_next
        return found


def load(source: str, name: str) -> LoadedProgram:
    """Execute generated source; returns its `PROGRAM`. Raises LoadError."""
    filename = f"<rapid {name}>"
    namespace: dict[str, Any] = {"__builtins__": {"__import__": _guarded_import},
                                 "__name__": f"rapid_program_{name}"}
    try:
        code = compile(source, filename, "exec")
        exec(code, namespace)  # noqa: S102 - the namespace has no builtins; imports are guarded
    except Exception as exc:
        raise LoadError(f"cannot load the compiled program {name}: {type(exc).__name__}: {exc}") \
            from None
    program = namespace.get("PROGRAM")
    if not isinstance(program, Program):
        raise LoadError(f"the compiled program {name} defines no PROGRAM")
    return LoadedProgram(program, source, filename)
