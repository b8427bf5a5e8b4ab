"""The language card: what a coding agent reads before it writes a program (`rapidc guide`, and the
MCP resource `rapid://card`).

Made from the sources of truth wherever there is one: the example program is checked (it must
check and lint clean), the kinds come from language/kinds.py, the units from language/units.py, the
budgets from language/limits.py, the builtins and their signatures from language/registry.py, the
standard primitives (roles, params, goal) from their files, and each common error's message and
help from checking a copy of the example with that one mistake in it. Only the prose is written
here. Imports neither numpy nor mujoco.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from importlib import resources

from rapid_dsl import __version__

EXAMPLE_PATH = "example.rapid"
EXAMPLE = """\
use stdlib.{push, flip}

# A primitive: the roles it acts on, the effect asked for (params), features resolved at every
# step, what success means, the cost the optimizer lowers, and the keypoints of the hand it moves.
primitive slide {
  goal "Slide the target over its support by the requested distance"
  roles { target: Object, support: Surface, hand: Manipulator }
  requires { on(target, support) }
  params { shift: Length in [1cm, 20cm] = 5cm }
  resolve {
    ahead = heading(target)
    moved = norm(horizontal(pos(target) - start(pos(target))))
  }
  success { abs(moved - shift) < 1cm; settled(target) }
  cost final = ((moved - shift) / 1cm)^2
  cost progress weight 0.1 = distance(hand, target) / 1cm
  motion {
    keypoint behind = pos(target) - (half_extent(target, along=ahead) + 2cm) * ahead + 8cm * up
    keypoint down = behind + (top(support) + 1cm - behind.z) * up gripper closed
    keypoint through = down + shift * ahead
    duration 2s
  }
  optimize { samples 32; iterations 4 }
  filter { extents(target).z < 15cm }
}

# A strategy: phases run primitives on its roles, with arguments computed at each phase's start.
strategy push_and_flip {
  goal "Push the box against the wall, then flip it up onto its edge"
  roles { box: Object, table: Surface, wall: Fixture, hand: Manipulator }
  requires { on(box, table); faces(wall, box); reachable(hand, box); reachable(hand, wall) }
  let margin = 1cm
  phase approach: push(target=box, support=table, hand=hand) {
    displacement = (distance(box, wall) - margin) * direction(box, wall)
  }
  phase tip: flip(target=box, support=table, fixture=wall, hand=hand) {
    angle = 90deg - tilt(box)
  }
  success { tilt(box) > 60deg; distance(box, wall) < 2cm }
}
"""


@dataclass(frozen=True, slots=True)
class Mistake:
    """A common error: the example with `right` replaced by `wrong` reports `code` first."""

    code: str
    right: str
    wrong: str


MISTAKES: tuple[Mistake, ...] = (
    Mistake("E0302", "distance(box, wall) < 2cm", "distance(box, wall) < 0.02"),
    Mistake("E0508", "(distance(box, wall) - margin) * direction(box, wall)",
            "5 * direction(box, wall)"),
    Mistake("E0508", "angle = 90deg - tilt(box)", "angle = 90"),
    Mistake("E0301", "let margin = 1cm", "let margin = 1cm + 10deg"),
    Mistake("E0308", "cost final = ((moved - shift) / 1cm)^2", "cost final = (moved - shift)^2"),
    Mistake("E0312", "extents(target).z < 15cm", "target.z < 15cm"),
    Mistake("E0205", "use stdlib.{push, flip}", "use stdlib.{psuh, flip}"),
    Mistake("E0501", "push(target=box, support=table, hand=hand)", "push(target=box, hand=hand)"),
    Mistake("E0504", "fixture=wall", "fixture=box"),
    Mistake("E0505", "    displacement = (distance(box, wall) - margin) * direction(box, wall)\n",
            ""),
    Mistake("E0509", "angle = 90deg - tilt(box)", "angle = 150deg"),
)

SYNTAX = """\
- A statement ends at a new line or `;`; `#` comments to the end of the line. Value names are
  `[a-z_][A-Za-z0-9_]*`; types and kinds are capitalized.
- `use stdlib.NAME`, `use stdlib.{a, b}`, `use "lib/x.rapid"` (relative to this file, inside its
  folder); `relation NAME(a: Body, ...) = BOOL`; `def NAME(x: Length, ...) -> TYPE = EXPR`.
- primitive: `goal`, `roles` (at least one Manipulator), `success`, `cost final` and `motion` are
  required; `requires` (roles only), `params`, `resolve`, `cost progress [weight W]`, `optimize`,
  `filter` optional; any order, each once.
- `params { p: Type [in [LOW, HIGH]] [= DEFAULT] }`: constants with units. `resolve` entries are
  evaluated at every step, in order; `start(e)` is `e` at the primitive's first step.
- `motion { keypoint K = POINT [yaw A] [pitch A] [roll A] [gripper open|closed] ... spread L;
  spread_angle A; duration T }`; keypoints are evaluated at the start and moved by the optimizer.
- `optimize { samples N; elites N; iterations N; seed N }`: defaults 64, min(8, samples), 6.
- strategy: `goal`, `roles` and phases required; `requires` (roles only), `let` (evaluated once,
  at the start), `success`, `filter` optional.
- `phase NAME: PRIM(prim_role=strategy_role, ...) { param = expr ... } [retry N] [on_fail
  continue]` maps every role of PRIM and gives every param without a default. A failed phase is
  tried again up to N (at most 5) more times from the state it reached; then it stops the strategy.
- `param = solve d: Point minimize EXPR subject { C1; C2 }`: an argument found by optimization.
- Expressions: `if c then a else b`, `or`, `and`, `not`, `< <= > >= == !=` (not chained),
  `+ - * /`, `x ^ 2` (integer exponent), `[x, y, z]`, `v.x`. Entities have no components:
  `pos(box).x`. A cost is Real: divide by a scale, `(d / 1cm)^2`."""


def card() -> str:
    """The card as Markdown."""
    return "\n".join(_lines()) + "\n"


def _lines() -> Iterator[str]:
    yield f"# The RAPID language card (rapidc {__version__})"
    yield ""
    yield ("Write a program, then `check` it (errors have codes and fixes; `explain CODE`), `lint`"
           " and `fmt` it,")
    yield ("`run` it on a scene, and `verify` it on seeded variants of the scene: revise it from"
           " the first failing clause.")
    yield ""
    yield "## A program"
    yield ""
    yield "```rapid"
    yield EXAMPLE.rstrip("\n")
    yield "```"
    yield ""
    yield "## Syntax"
    yield ""
    yield SYNTAX
    yield ""
    yield "## Types, units, budgets"
    yield ""
    yield from _types()
    yield ""
    yield "## Builtins"
    yield ""
    yield from _builtins()
    yield ""
    yield "## The standard library (`use stdlib.NAME`)"
    yield ""
    yield from _stdlib()
    yield ""
    yield "## Common errors and their fixes"
    yield ""
    yield from _mistakes()
    yield ""
    yield ("More: docs/language.md (MCP resource rapid://language), rapid://builtins, "
           "rapid://stdlib/NAME, rapid://diagnostics.")


def _types() -> Iterator[str]:
    from rapid_dsl.language.kinds import KIND_PARENTS
    from rapid_dsl.language.limits import MAX_DURATION, MAX_ITERATIONS, MAX_KEYPOINTS, MAX_SAMPLES
    from rapid_dsl.language.units import NAMED_DIMS, UNITS, dim_name

    kinds = ", ".join(k if not parents else f"{k} <: {parents[0]}"
                      for k, parents in KIND_PARENTS.items())
    yield f"- Entity kinds (role types): {kinds}. A subkind fills a role of its kind."
    yield (f"- Quantities: {', '.join(NAMED_DIMS)}, and products, quotients and integer powers "
           "(`Length / Time`, `Length^2`); `Vec[Q]`, `Point` = `Vec[Length]`, `Direction` = "
           "`Vec[Real]`; `Bool`.")
    by_dim: dict[str, list[str]] = {}
    for unit, (dim, _) in UNITS.items():
        by_dim.setdefault(dim_name(dim), []).append(unit)
    units = "; ".join(f"{name} {' '.join(units)}" for name, units in by_dim.items())
    yield (f"- Units, written after the number (`5cm`, `90deg`): {units}. A bare number is Real: "
           "`< 0.05` does not compare with a Length, `< 5cm` does.")
    yield (f"- Budgets at most: samples {MAX_SAMPLES}, iterations {MAX_ITERATIONS}, motion "
           f"duration {MAX_DURATION:g}s, {MAX_KEYPOINTS} keypoints.")


def _builtins() -> Iterator[str]:
    from rapid_dsl.language.registry import BUILTINS

    builtins = list(BUILTINS.values())
    yield "Geometry of scene entities, evaluated on the simulated state:"
    for b in builtins:
        if b.kind == "function" and not b.symbolic:
            yield f"- `{b.signature}`: {_short(b.doc)}"
    yield ("Math (`Q`, `Q1`, `Q2` are dimension variables; these also work inside `solve`): "
           + ", ".join(f"`{b.signature}`" for b in builtins
                       if b.kind == "function" and b.symbolic) + ".")
    yield "Relations (Bool; they bind roles, check `requires`, judge `success` and `filter`):"
    for b in builtins:
        if b.kind == "relation":
            yield f"- `{b.signature}`: {b.doc}"
    yield "Constants: " + ", ".join(f"`{b.signature}` ({b.doc.rstrip('.')})" for b in builtins
                                    if b.kind == "constant") + "."


def _short(doc: str) -> str:
    """A builtin's doc up to its first `:` or `;` (the detail stays in docs/builtins.md)."""
    cut = min((i for i in (doc.find(": "), doc.find("; ")) if i > 0), default=len(doc))
    return doc[:cut].rstrip(".") + "."


def _stdlib() -> Iterator[str]:
    for _, primitive in stdlib_primitives():
        yield f"- {primitive}"


def stdlib_primitives() -> list[tuple[str, str]]:
    """(name, `name(roles) params: goal`) of every standard primitive, read from its file."""
    from rapid_dsl.frontend import syntax as ast
    from rapid_dsl.frontend.formatter import format_expr, format_type
    from rapid_dsl.frontend.parser import parse_module

    found = []
    for source in sorted(stdlib_sources()):
        name = source.removesuffix(".rapid")
        module, _ = parse_module(stdlib_sources()[source], f"<stdlib>/{source}")
        for decl in module.decls if module is not None else ():
            if not isinstance(decl, ast.Primitive) or decl.name.name != name:
                continue
            roles, params, goal = "", [], ""
            for block in decl.blocks:
                if isinstance(block, ast.Roles):
                    roles = ", ".join(f"{r.name.name}: {format_type(r.type)}"
                                      for r in block.roles)
                elif isinstance(block, ast.Params):
                    for p in block.params:
                        text = f"{p.name.name}: {format_type(p.type)}"
                        if p.low is not None and p.high is not None:
                            text += f" in [{format_expr(p.low)}, {format_expr(p.high)}]"
                        if p.default is not None:
                            text += f" = {format_expr(p.default)}"
                        params.append(text)
                elif isinstance(block, ast.Goal):
                    goal = block.text
            found.append((name, f"`{name}({roles})` params `{', '.join(params) or 'none'}`: "
                                f"{goal}"))
    return found


def stdlib_sources() -> dict[str, str]:
    """File name -> text of every standard-library file."""
    folder = resources.files("rapid_dsl.stdlib_primitives")
    return {f.name: f.read_text(encoding="utf-8") for f in folder.iterdir()
            if f.name.endswith(".rapid")}


def _mistakes() -> Iterator[str]:
    from rapid_dsl.frontend.driver import check_text

    for mistake in MISTAKES:
        wrong = EXAMPLE.replace(mistake.right, mistake.wrong, 1)
        errors = [d for d in check_text(wrong, EXAMPLE_PATH).diagnostics if d.is_error]
        if not errors or errors[0].code != mistake.code or wrong == EXAMPLE:
            raise AssertionError(f"card: the {mistake.code} example reports "
                                 f"{errors[0].code if errors else 'nothing'}")
        first = errors[0]
        shown_wrong, shown_right = mistake.wrong.strip(), mistake.right.strip()
        fix = f"`{shown_right}`" if shown_wrong else f"add `{shown_right}`"
        change = f"`{shown_wrong}` -> {fix}" if shown_wrong else fix
        help_text = f"; {first.help}" if first.help else ""
        yield f"- {first.code} {first.message}: {change}{help_text}"
