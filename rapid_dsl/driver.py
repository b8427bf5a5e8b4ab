"""The front end's phase order, in one place: parse -> resolve `use` -> check -> lint.

Light on purpose (no numpy, mujoco, jinja2 or pydantic on this path): `rapidc check` starts fast.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field

from rapid_dsl import ir
from rapid_dsl import syntax as ast
from rapid_dsl.diagnostics import Diagnostic, Span, error, sort_key
from rapid_dsl.modules import StdlibLocation

__all__ = ["CheckResult", "InputError", "check_file", "check_text", "parse_source"]

YAML_SUFFIXES = (".yaml", ".yml")
# Expressions nest at most check.expressions.MAX_DEPTH levels, a few frames each: this leaves room.
_RECURSION_LIMIT = 5000


class InputError(Exception):
    """The root file cannot be read (the CLI exits with status 2)."""

    def __init__(self, message: str) -> None:
        self.message = message
        super().__init__(message)


@dataclass(slots=True)
class CheckResult:
    program: ir.Program | None                  # None when any diagnostic is an error
    diagnostics: list[Diagnostic]               # sorted by path, line, column, code
    sources: dict[str, str] = field(default_factory=dict)   # path -> text, for carets

    @property
    def ok(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)


def parse_source(text: str, path: str) -> tuple[ast.Module | None, list[Diagnostic]]:
    """Parse a `.rapid` file, or a program in the YAML form when the name ends in .yaml/.yml."""
    if path.endswith(YAML_SUFFIXES):
        from rapid_dsl.yaml_form import parse_yaml_module
        return parse_yaml_module(text, path)
    from rapid_dsl.parser import parse_module
    return parse_module(text, path)


def check_text(text: str, path: str, *, lint: bool = False,
               stdlib: StdlibLocation | None = None) -> CheckResult:
    """Check a program given as text; `path` names it in diagnostics and anchors relative `use`s."""
    sources = {path: text}
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, _RECURSION_LIMIT))
    try:
        diagnostics, program = _check(text, path, lint, stdlib, sources)
    except RecursionError:
        diagnostics = [error("E0409", "the program is nested too deeply to check",
                             Span.point(path), help="split long expressions with `let` or "
                             "resolve entries")]
        program = None
    finally:
        sys.setrecursionlimit(limit)
    diagnostics.sort(key=sort_key)
    if any(d.is_error for d in diagnostics):
        program = None
    return CheckResult(program, diagnostics, sources)


def check_file(path: str, *, lint: bool = False,
               stdlib: StdlibLocation | None = None) -> CheckResult:
    """Check the program in `path`. Raises InputError when the file cannot be read."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a folder") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text") from None
    except OSError as exc:
        raise InputError(f"{path}: {exc.strerror or exc}") from None
    return check_text(text, path, lint=lint, stdlib=stdlib)


def _check(text: str, path: str, lint: bool, stdlib: StdlibLocation | None,
           sources: dict[str, str]) -> tuple[list[Diagnostic], ir.Program | None]:
    from rapid_dsl.checker import check_program
    from rapid_dsl.modules import load_modules

    module, diagnostics = parse_source(text, path)
    graph = load_modules(text, path, module, parse=parse_source, stdlib=stdlib)
    for file in graph.files:
        sources.setdefault(file.path, file.text)
    diagnostics = [*diagnostics, *graph.diagnostics]
    program, found = check_program(graph)
    diagnostics.extend(found)
    if any(d.is_error for d in diagnostics):
        return diagnostics, None
    if lint:
        from rapid_dsl.lint import lint_program
        diagnostics.extend(lint_program(program, graph))
    return diagnostics, program
