"""The plan: everything the module template needs, already decided and rendered as Python text.

`lower` builds it from the typed IR; `render` interpolates it into the template. Lines carry their
own relative indentation, and `# file.rapid:LINE` markers are ordinary lines, so the template only
loops and the line map is read back from the rendered source.
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

    title: str                  # "primitive push"
    origin: str                 # "stdlib/push.rapid:3"
    functions: tuple[FunctionPlan, ...]
    assignment: tuple[str, ...]  # lines of `push = RT.Primitive(...)` (empty for def/relation)


@dataclass(frozen=True, slots=True)
class ModulePlan:
    header: str                 # first comment line
    doc: str                    # module docstring
    imports: tuple[str, ...]    # sorted import lines
    abi: int
    sections: tuple[SectionPlan, ...]
    program: tuple[str, ...]    # lines of `PROGRAM = RT.Program(...)`
