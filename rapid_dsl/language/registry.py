"""The builtin registry: every function, relation and constant a program may name.

This table is the one source of truth. The checker reads the signatures to type programs; the
runtime implements exactly these names (`rapid_dsl.runtime.builtins` in numpy over batches of
rollouts, and `rapid_dsl.runtime.symbolic` in CasADi for the ones marked `symbolic`). Tests assert
that both sides cover the same names. Nothing outside this table can be called from a program.

Types are written in the language's own type syntax. `Q`, `Q1` and `Q2` are dimension variables:
`norm(v: Vec[Q]) -> Q` works for any quantity. `sqrt(Q)` is the square root of a dimension (its
exponents must be even) and `Q1 * Q2` a product.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

BuiltinKind = Literal["function", "relation", "constant"]


@dataclass(frozen=True, slots=True)
class Param:
    name: str
    type: str


@dataclass(frozen=True, slots=True)
class Builtin:
    name: str
    kind: BuiltinKind
    params: tuple[Param, ...]
    returns: str
    doc: str
    symbolic: bool = False  # has a CasADi version, so it may depend on a `solve` variable

    @property
    def signature(self) -> str:
        args = ", ".join(f"{p.name}: {p.type}" for p in self.params)
        if self.kind == "constant":
            return f"{self.name}: {self.returns}"
        if self.kind == "relation":
            return f"relation {self.name}({args})"
        return f"{self.name}({args}) -> {self.returns}"


def _sig(text: str) -> tuple[Param, ...]:
    """`"a: Body, b: Body"` -> params."""
    params = []
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, _, type_text = item.partition(":")
        params.append(Param(name.strip(), type_text.strip()))
    return tuple(params)


def _fn(name: str, params: str, returns: str, doc: str, *, symbolic: bool = False) -> Builtin:
    return Builtin(name, "function", _sig(params), returns, doc, symbolic)


def _rel(name: str, params: str, doc: str) -> Builtin:
    return Builtin(name, "relation", _sig(params), "Bool", doc)


_BUILTINS: tuple[Builtin, ...] = (
    # Geometry of scene entities (evaluated on recorded states, never symbolic).
    _fn("pos", "b: Body", "Point", "World position of the body's centre."),
    _fn("extents", "b: Body", "Vec[Length]", "Full size of the body along its own x, y, z axes."),
    _fn("distance", "a: Body, b: Body", "Length",
        "Gap between the two bodies' oriented bounding boxes: the largest gap between their "
        "projections on the line of their centres or on either box's axes (exact when a face "
        "separates them); 0 when they touch or overlap."),
    _fn("direction", "a: Body, b: Body", "Direction",
        "Horizontal unit vector from a's centre toward b's centre."),
    _fn("height", "b: Body", "Length", "World z of the body's centre."),
    _fn("bottom", "b: Body", "Length", "World z of the body's lowest point."),
    _fn("top", "b: Body", "Length", "World z of the body's highest point."),
    _fn("yaw", "b: Body", "Angle", "Heading of the body's x axis about world up, in (-pi, pi]."),
    _fn("tilt", "b: Body", "Angle", "Angle between the body's z axis and world up, in [0, pi]."),
    _fn("speed", "b: Body", "Length / Time", "Linear speed of the body's centre."),
    _fn("spin", "b: Body", "Angle / Time", "Angular speed of the body."),
    _fn("rotation", "b: Body, about: Direction", "Angle",
        "Signed rotation of the body about the axis since the running primitive's start."),
    _fn("contact_point", "o: Object, away_from: Body", "Point",
        "Point on o's side that faces away from `away_from`, at o's centre height: where to push "
        "o toward `away_from`."),
    _fn("edge_axis", "o: Object, f: Fixture, s: Surface", "Direction",
        "Horizontal axis of o's bottom edge nearest f, about which o tips against f on s."),
    _fn("normal_toward", "f: Fixture, o: Body", "Direction",
        "Outward normal of f's face that looks toward o."),
    _fn("half_extent", "b: Body, along: Direction", "Length",
        "Distance from b's centre to its bounding box's surface along a world direction."),
    _fn("heading", "b: Body", "Direction", "Horizontal unit vector along the body's x axis."),
    _fn("narrow_side", "b: Body", "Direction",
        "Horizontal unit vector across which b's box is narrowest in the world frame, whatever "
        "its orientation: the direction a top-down grasp closes along."),
    _fn("palm_depth", "m: Manipulator", "Length",
        "Distance from the hand's palm (the finger roots) to the tool point along the fingers."),
    _fn("opening", "m: Manipulator", "Length", "Distance between the gripper's fingers."),
    _fn("disturbance", "m: Manipulator", "Length",
        "The farthest any Object of the scene has moved since the running primitive's start: "
        "what a motion of the hand through free space must keep small."),
    # Math, generic in the dimension.
    _fn("abs", "x: Q", "Q", "Absolute value.", symbolic=True),
    _fn("min", "a: Q, b: Q", "Q", "Smaller of two values.", symbolic=True),
    _fn("max", "a: Q, b: Q", "Q", "Larger of two values.", symbolic=True),
    _fn("clamp", "x: Q, lo: Q, hi: Q", "Q", "x limited to [lo, hi].", symbolic=True),
    _fn("sqrt", "x: Q", "sqrt(Q)", "Square root; the dimension's exponents must be even.",
        symbolic=True),
    _fn("sin", "a: Angle", "Real", "Sine.", symbolic=True),
    _fn("cos", "a: Angle", "Real", "Cosine.", symbolic=True),
    _fn("atan2", "y: Q, x: Q", "Angle", "Angle of the vector (x, y).", symbolic=True),
    _fn("norm", "v: Vec[Q]", "Q", "Euclidean length of a vector.", symbolic=True),
    _fn("dot", "a: Vec[Q1], b: Vec[Q2]", "Q1 * Q2", "Dot product.", symbolic=True),
    _fn("cross", "a: Vec[Q1], b: Vec[Q2]", "Vec[Q1 * Q2]", "Cross product.", symbolic=True),
    _fn("normalize", "v: Vec[Q]", "Direction", "Unit vector along v.", symbolic=True),
    _fn("horizontal", "v: Vec[Q]", "Vec[Q]", "v with its z component set to 0.", symbolic=True),
    # Relations: Bool-valued, executable; the same predicate binds, checks success and filters.
    _rel("on", "o: Object, s: Surface",
         "o rests on s: o's bottom is within 1 cm of s's top, o's centre is over s, they touch."),
    _rel("touching", "a: Body, b: Body", "MuJoCo reports a contact between a and b."),
    _rel("faces", "f: Fixture, o: Object",
         "f stands beside o: o's centre lies within f's horizontal span along f's face, on the "
         "same support, within 50 cm."),
    _rel("reachable", "m: Manipulator, b: Body", "b's centre is inside the robot's workspace."),
    _rel("inside", "o: Object, f: Fixture", "o's centre lies within f's bounding box footprint."),
    _rel("settled", "o: Object", "o moves slower than 1 cm/s and turns slower than 0.1 rad/s."),
    _rel("holding", "m: Manipulator, o: Object",
         "Both fingers of m squeeze o from opposite sides, o reaching between them past the "
         "fingertips."),
    _rel("upright", "o: Object", "o's z axis is within 10 deg of world up."),
    _rel("undisturbed", "m: Manipulator",
         "No Object of the scene has moved more than 1 cm since the running primitive's start."),
    # Constants.
    Builtin("up", "constant", (), "Direction", "World up, [0, 0, 1].", symbolic=True),
    Builtin("pi", "constant", (), "Real", "3.14159...", symbolic=True),
)

BUILTINS: dict[str, Builtin] = {b.name: b for b in _BUILTINS}


def lookup(name: str) -> Builtin | None:
    return BUILTINS.get(name)
