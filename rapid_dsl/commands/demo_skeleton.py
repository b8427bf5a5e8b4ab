"""A strategy skeleton from a demonstration analysis (`rapidc demo analyze --skeleton`).

Each phase of the analysis (runtime/demonstrations/analysis.py) that shows a standard primitive's
effect becomes a phase running that primitive, with the measured effect as its argument; the
entities it touched become the strategy's roles. It is where a program starts, not a general one:
the numbers are the demonstration's, to be replaced by relations of the scene (docs/demos.md). What
the standard primitives take (their roles, params and ranges) is read from the standard library
itself, and a measured value outside its param's range is clamped into it, with a comment saying
so, so the skeleton always checks clean.

Role names come from entity names, made into names of the language; anything printed from the
track (entity names) appears only inside comments, escaped to printable ASCII.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from functools import lru_cache
from importlib import resources
from typing import Any

from rapid_dsl.frontend import ir
from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.runtime.demonstrations.analysis import literal

STRATEGY = "demonstration"
KINDS = {"target": "Object", "support": "Surface", "fixture": "Fixture", "hand": "Manipulator"}
NAME_LIMIT = 40


class SkeletonProblem(Exception):
    """The analysis has no phase a standard primitive can run."""


def skeleton(analysis: Mapping[str, Any]) -> str:
    """The `.rapid` text of the skeleton strategy, in the canonical layout (`rapidc fmt`)."""
    phases = [p for p in analysis["phases"] if p["primitive"] is not None and p["arguments"]]
    if not phases:
        raise SkeletonProblem("no phase of the track shows the effect of a standard primitive: "
                              "no skeleton written")
    primitives = _stdlib()
    names = _Names()
    hand = names.role(analysis["hand"], "hand", "Manipulator", preferred="hand")
    lines: list[str] = []
    used: list[str] = []
    for phase in analysis["phases"]:
        if phase["primitive"] is None or not phase["arguments"]:
            lines.append(f"  # {_when(phase)}: {phase['kind']} of "
                         f"{_quoted(phase['object'])}, no standard primitive")
            continue
        primitive = primitives[phase["primitive"]]
        if primitive.name not in used:
            used.append(primitive.name)
        roles = []
        for role in primitive.roles:
            entity = {"target": phase["object"], "support": phase["support"],
                      "fixture": phase["fixture"]}.get(role.name)
            filled = hand if role.kind == "Manipulator" else \
                names.role(entity, role.name, role.kind)
            roles.append(f"{role.name}={filled}")
        phase_name = names.fresh(f"{phase['kind']}_{phase['index']}")
        lines.append(f"  # {_when(phase)}: {_effect(phase)}")
        lines.append(f"  phase {phase_name}: {primitive.name}({', '.join(roles)}) {{")
        for param in primitive.params:
            if param.name in phase["arguments"]:
                text, note = _argument(param, phase["arguments"][param.name],
                                       phase["argument_units"][param.name], primitive.name)
                if note:
                    lines.append(f"    # {note}")
                lines.append(f"    {param.name} = {text}")
        lines.append("  }")
    order = list(KINDS.values())      # as programs list them: objects first, the hand last
    declared = sorted(names.roles.items(), key=lambda item: order.index(item[1][0]))
    kinds = ", ".join(f"{role}: {kind}" for role, (kind, _) in declared)
    cast = "\n".join(f"#   {role} = {_quoted(entity) if entity else 'any ' + kind}"
                     for role, (kind, entity) in declared)
    steps = ", then ".join(f"{p['kind'].replace('_', ' ')} {names.of(p['object'])}"
                           for p in phases)
    text = (f"# A strategy skeleton from a demonstration (rapidc demo analyze --skeleton): each\n"
            f"# phase runs the standard primitive whose effect the demonstration shows, with the\n"
            f"# measured effect as its argument. Before reusing it, replace the numbers with\n"
            f"# relations of the scene (distances, directions) and add requires and success.\n"
            f"# Roles, and the entities of the track they stand for:\n{cast}\n"
            f"use stdlib.{{{', '.join(used)}}}\n\n"
            f"strategy {STRATEGY} {{\n"
            f'  goal "Do as the demonstration did: {steps}"\n'
            f"  roles {{ {kinds} }}\n" + "\n".join(lines) + "\n}\n")
    return _canonical(text)


def _argument(param: ir.Param, value: Any, unit: str, primitive: str) -> tuple[str, str]:
    """The argument's text, clamped into the param's range, and a note when it was clamped."""
    low, high = param.low, param.high
    if isinstance(value, list):
        length = math.sqrt(sum(x * x for x in value))
        if high is not None and length > high:
            scaled = [x * high / length for x in value]
            return literal(scaled, unit), (f"measured {literal(value, unit)}, longer than "
                                           f"{primitive}'s {param.name} range allows")
        return literal(value, unit), ""
    clamped = min(max(value, -math.inf if low is None else low),
                  math.inf if high is None else high)
    if clamped != value:
        bounds = ", ".join("" if b is None else literal(b, unit) for b in (low, high))
        return literal(clamped, unit), (f"measured {literal(value, unit)}, outside the range "
                                        f"[{bounds}] of {primitive}'s {param.name}: clamped")
    return literal(value, unit), ""


class _Names:
    """Names of the language for the track's entities (roles) and the phases, all distinct."""

    def __init__(self) -> None:
        self.taken = set(_keywords()) | set(BUILTINS) | {"start", STRATEGY}
        self.roles: dict[str, tuple[str, str | None]] = {}    # role -> (kind, entity)
        self.entities: dict[tuple[str | None, str], str] = {}  # (entity, kind) -> role

    def role(self, entity: str | None, fallback: str, kind: str, *,
             preferred: str | None = None) -> str:
        """The role standing for `entity` (None: any entity of the kind), made on first use."""
        key = (entity, kind)
        if key not in self.entities:
            name = self.fresh(preferred or (_identifier(entity) if entity else fallback),
                              fallback)
            self.entities[key] = name
            self.roles[name] = (kind, entity)
        return self.entities[key]

    def of(self, entity: str) -> str:
        return self.entities.get((entity, "Object"), "it")

    def fresh(self, wanted: str, fallback: str = "name") -> str:
        base = wanted if wanted and not wanted[0].isdigit() else f"{fallback}_{wanted}".rstrip("_")
        name, n = base, 1
        while name in self.taken:
            n += 1
            name = f"{base}_{n}"
        self.taken.add(name)
        return name


def _identifier(text: str) -> str:
    """`Red Box #2` -> `red_box_2`: lower case letters, digits and `_`, no leading `_`."""
    name = re.sub(r"[^a-z0-9_]+", "_", text.lower()).strip("_")
    return name[:NAME_LIMIT].rstrip("_")


@lru_cache(maxsize=1)
def _keywords() -> frozenset[str]:
    """The grammar's keywords: the quoted words of grammar/rapid.lark."""
    grammar = resources.files("rapid_dsl.grammar").joinpath("rapid.lark").read_text("utf-8")
    return frozenset(re.findall(r'"([a-z_]+)"', grammar))


@lru_cache(maxsize=1)
def _stdlib() -> dict[str, ir.Primitive]:
    """The standard primitives a phase kind names, as the checker reads them."""
    from rapid_dsl.frontend.driver import check_text
    from rapid_dsl.runtime.demonstrations.analysis import ARGUMENTS

    result = check_text(f"use stdlib.{{{', '.join(ARGUMENTS)}}}\n", "<skeleton>.rapid")
    assert result.program is not None, result.diagnostics
    return {name: result.program.primitive(name) for name in ARGUMENTS}


def _canonical(text: str) -> str:
    from rapid_dsl.frontend.formatter import format_source

    formatted, _ = format_source(text, "<skeleton>.rapid")
    return formatted if formatted is not None else text


def _when(phase: Mapping[str, Any]) -> str:
    return f"{phase['start']:.2f}-{phase['end']:.2f} s"


def _effect(phase: Mapping[str, Any]) -> str:
    effect = phase["effect"]
    text = (f"{_quoted(phase['object'])} moved {literal(effect['displacement'], 'm')} "
            f"({literal(effect['distance'], 'm')})")
    if effect["rotation_axis"] is not None:
        text += (f", turned {literal(effect['rotation_angle'], 'rad')} about "
                 f"{literal(effect['rotation_axis'], '')}")
    return text


def _quoted(name: str | None) -> str:
    """A track's name inside a comment: a JSON string, printable ASCII on one line."""
    return json.dumps(name, ensure_ascii=True) if name is not None else "?"
