"""The front end's phase order, in one place: parse -> resolve `use` -> check -> lint.

Light on purpose (no numpy, mujoco, jinja2 or pydantic on this path): `rapidc check` starts fast.
"""

from __future__ import annotations

import gc
import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.modules import ModuleGraph, StdlibLocation
from rapid_dsl.language.diagnostics import Diagnostic, Span, error, sort_key
from rapid_dsl.language.files import FileProblem, read_text

__all__ = ["CheckResult", "InputError", "check_file", "check_text", "parse_source"]

YAML_SUFFIXES = (".yaml", ".yml")
# Expressions nest at most parser.MAX_DEPTH levels, a few frames each: this leaves room.
_RECURSION_LIMIT = 5000


@contextmanager
def deep_recursion() -> Iterator[None]:
    """Room for the recursion of checking and formatting the deepest program the parser accepts
    (parser.MAX_DEPTH levels); callers turn a RecursionError beyond it into E0409 (`too_deep`)."""
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, _RECURSION_LIMIT))
    try:
        yield
    finally:
        sys.setrecursionlimit(limit)


def too_deep(path: str, what: str = "check") -> Diagnostic:
    return error("E0409", f"the program is nested too deeply to {what}", Span.point(path),
                 help="split long expressions with `let` or resolve entries")


class InputError(Exception):
    """The root file cannot be read (the CLI exits with status 2)."""

    def __init__(self, message: str) -> None:
        self.message = message
        super().__init__(message)


@dataclass(slots=True)
class CheckResult:
    """What the front end made of a program, kept when it has errors too: the language server
    reads the syntax tree, the module graph and the IR of a program that does not check yet."""

    program: ir.Program | None                  # None when any diagnostic is an error
    diagnostics: list[Diagnostic]               # sorted by path, line, column, code
    sources: dict[str, str] = field(default_factory=dict)   # path -> text, for carets
    inputs: list[str] = field(default_factory=list)         # every file read, as on disk
    module: ast.Module | None = None            # the root file's syntax tree (None: no parse)
    graph: ModuleGraph | None = None            # the resolved `use` graph
    checked: ir.Program | None = None           # what the checker built, errors and all

    @property
    def ok(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)


def parse_source(text: str, path: str) -> tuple[ast.Module | None, list[Diagnostic]]:
    """Parse a `.rapid` file, or a program in the YAML form when the name ends in .yaml/.yml.
    A leading BOM and CR/CRLF line ends are fine (`syntax.source_text`)."""
    text = ast.source_text(text)
    if path.endswith(YAML_SUFFIXES):
        from rapid_dsl.frontend.yaml import parse_yaml_module
        return parse_yaml_module(text, path)
    from rapid_dsl.frontend.parser import parse_module
    return parse_module(text, path)


def check_text(text: str, path: str, *, lint: bool = False,
               stdlib: StdlibLocation | None = None,
               allowed_dirs: Sequence[str | os.PathLike[str]] = ()) -> CheckResult:
    """Check a program given as text; `path` names it in diagnostics and anchors relative `use`s,
    which must stay in its folder tree or in one of `allowed_dirs`. Text from an editor may start
    with a BOM and end lines with CR or CRLF: positions are those of `syntax.source_text`."""
    text = ast.source_text(text)
    sources = {path: text}
    inputs: list[str] = []
    # The parse tree, AST and IR are acyclic, so reference counting frees them; the cycle
    # collector's passes over their growing heap only made checking super-linear (20,000 lines:
    # 4.5 s with it, 1.7 s without). What cycles there are go at the next collection after this.
    result = CheckResult(None, [], sources, inputs)
    collecting = gc.isenabled()
    gc.disable()
    try:
        with deep_recursion():
            _check(text, path, lint, stdlib, allowed_dirs, result)
    except RecursionError:
        result.diagnostics, result.checked = [too_deep(path)], None
    finally:
        if collecting:
            gc.enable()
    result.diagnostics.sort(key=sort_key)
    if not any(d.is_error for d in result.diagnostics):
        result.program = result.checked
    return result


def check_file(path: str, *, lint: bool = False, stdlib: StdlibLocation | None = None,
               allowed_dirs: Sequence[str | os.PathLike[str]] = ()) -> CheckResult:
    """Check the program in `path` (a regular UTF-8 file within the input size limit).
    Raises InputError when the file cannot be read."""
    try:
        text = read_text(path)
    except FileProblem as exc:
        raise InputError(f"{path}: {exc}") from None
    return check_text(text, path, lint=lint, stdlib=stdlib, allowed_dirs=allowed_dirs)


def _check(text: str, path: str, lint: bool, stdlib: StdlibLocation | None,
           allowed_dirs: Sequence[str | os.PathLike[str]], result: CheckResult) -> None:
    """The phases in order, filling `result` as each one finishes."""
    from rapid_dsl.frontend.checker import check_program
    from rapid_dsl.frontend.modules import load_modules

    result.module, diagnostics = parse_source(text, path)
    result.diagnostics = diagnostics
    graph = result.graph = load_modules(text, path, result.module, parse=parse_source,
                                        stdlib=stdlib, allowed_dirs=allowed_dirs)
    for file in graph.files:
        result.sources.setdefault(file.path, file.text)
        if file.location is not None:
            result.inputs.append(file.location)
    diagnostics.extend(graph.diagnostics)
    result.checked, found = check_program(graph)
    diagnostics.extend(found)
    if lint and not any(d.is_error for d in diagnostics):
        from rapid_dsl.frontend.lint import lint_program
        diagnostics.extend(lint_program(result.checked, graph))
