"""ModulePlan -> GeneratedModule: the only place that renders templates (jinja2, StrictUndefined).

The template interpolates what `lower` decided. The line map is read back from the rendered source:
every `# SOURCES[i]:LINE` marker maps the generated lines below it to that line of `SOURCES[i]`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path

import jinja2

from rapid_dsl.compiler.plan import ModulePlan
from rapid_dsl.runtime.program import markers

TEMPLATES = Path(__file__).resolve().parent / "templates"


@dataclass(frozen=True, slots=True)
class LineMap:
    """(generated line, source path, source line) for every marker, in generated-line order."""

    entries: tuple[tuple[int, str, int], ...]

    def lookup(self, generated_line: int) -> tuple[str, int] | None:
        """The `.rapid` location of a generated line: the nearest marker at or above it."""
        found = None
        for line, path, source_line in self.entries:
            if line > generated_line:
                break
            found = (path, source_line)
        return found


@dataclass(frozen=True, slots=True)
class GeneratedModule:
    source: str
    line_map: LineMap


@cache
def _environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(TEMPLATES),
        undefined=jinja2.StrictUndefined,
        autoescape=False,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
    )


def render(plan: ModulePlan) -> GeneratedModule:
    """Render the module template for `plan` and read its line map."""
    source = _environment().get_template("module.py.jinja").render(plan=plan)
    entries = tuple((number, plan.files[index], line) for number, index, line in markers(source))
    return GeneratedModule(source, LineMap(entries))
