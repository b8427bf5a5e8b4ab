"""The source files a generated module comes from: how it names them, and its line markers.

A module names each file once, in `SOURCES` (the program's own file first, then others in the
order markers first need them); a marker comment `# SOURCES[i]:LINE` holds only an index into it
and a line number. Names are relative to the program's folder; standard-library files keep their
`<stdlib>/NAME.rapid` form; anything else is shown by its base name.
"""

from __future__ import annotations

import os
import posixpath

from rapid_dsl.frontend.modules import STDLIB_PREFIX
from rapid_dsl.language.diagnostics import Span
from rapid_dsl.runtime.program import marker


class SourceFiles:
    def __init__(self, program_path: str) -> None:
        self.root = posixpath.dirname(_slashes(program_path))
        self._index: dict[str, int] = {self.display(program_path): 0}

    @property
    def names(self) -> tuple[str, ...]:
        """The file names, in SOURCES order."""
        return tuple(self._index)

    def origin(self, span: Span) -> str:
        """`FILE:LINE` for run-time reports (a string literal in the module)."""
        return f"{self.display(span.path)}:{span.line}"

    def marker(self, span: Span) -> str:
        """The line-marker comment for `span`: an index into SOURCES and a line number."""
        index = self._index.setdefault(self.display(span.path), len(self._index))
        return marker(index, span.line)

    def display(self, path: str) -> str:
        """Stable file names: relative to the program's folder, stdlib as is."""
        path = _slashes(path)
        if path.startswith(STDLIB_PREFIX) or not posixpath.isabs(path) and not self.root:
            return path
        if self.root and (path == self.root or path.startswith(self.root + "/")):
            return posixpath.relpath(path, self.root)
        return posixpath.basename(path)


def _slashes(path: str) -> str:
    """`path` with `/` between folders: only a Windows separator is replaced (on POSIX a `\\`
    is part of a file's name)."""
    return path.replace(os.sep, "/") if os.sep != "/" else path
