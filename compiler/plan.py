"""The plan: everything the module template needs, already decided and rendered as Python text.

`lower` builds it from the typed IR; `render` interpolates it into the template. Lines carry their
own relative indentation, and `# SOURCES[i]:LINE` markers are ordinary lines, so the template only
loops and the line map is read back from the rendered source. Every piece of program text in these
lines is already a string literal; comments and docstrings here are generated words only.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class FunctionPlan:
    """One generated function: `def name(params) -> returns:` with a docstring and body lines."""

    name: str
    params: str                 # "C: RT.Context" or "F, target, support"
    returns: str                # annotation text, "" for none
    doc: str
    body: tuple[str, ...]       # lines relative to the function body's indentation


@dataclass(frozen=True, slots=True)
class SectionPlan:
    """One declaration: a banner, its functions, then the statement that builds its object."""

    title: str                  # the kind of declaration: "primitive"
    marker: str                 # "# SOURCES[1]:3", the declaration's line
    functions: tuple[FunctionPlan, ...]
    assignment: tuple[str, ...]  # lines of `push = RT.Primitive(...)` (empty for def/relation)


@dataclass(frozen=True, slots=True)
class ModulePlan:
    header: str                 # first comment line
    doc: str                    # module docstring
    imports: tuple[str, ...]    # sorted import lines
    abi: int
    files: tuple[str, ...]      # source file names; a marker's index points into them
    sources: tuple[str, ...]    # lines of `SOURCES = (...)`: those names, as literals
    sections: tuple[SectionPlan, ...]
    program: tuple[str, ...]    # lines of `PROGRAM = RT.Program(...)`
