"""Physical dimensions and unit suffixes: one table for the language, scene files and the runtime.

A dimension is an exponent vector over the base dimensions (length, angle, mass, time). Angle is a
base dimension of its own so that `3cm + 10deg` is an error. Values are stored in SI
(m, rad, kg, s).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

BASE_DIMENSIONS = ("length", "angle", "mass", "time")


@dataclass(frozen=True, slots=True)
class Dim:
    """Exponents of length, angle, mass and time."""

    length: int = 0
    angle: int = 0
    mass: int = 0
    time: int = 0

    def __mul__(self, other: Dim) -> Dim:
        return Dim(*(a + b for a, b in zip(self.exponents, other.exponents, strict=True)))

    def __truediv__(self, other: Dim) -> Dim:
        return Dim(*(a - b for a, b in zip(self.exponents, other.exponents, strict=True)))

    def __pow__(self, power: int) -> Dim:
        return Dim(*(a * power for a in self.exponents))

    @property
    def exponents(self) -> tuple[int, int, int, int]:
        return (self.length, self.angle, self.mass, self.time)

    @property
    def is_dimensionless(self) -> bool:
        return self == DIMENSIONLESS

    def __str__(self) -> str:
        return dim_name(self)


DIMENSIONLESS = Dim()
LENGTH = Dim(length=1)
ANGLE = Dim(angle=1)
MASS = Dim(mass=1)
TIME = Dim(time=1)
FORCE = Dim(length=1, mass=1, time=-2)
VELOCITY = Dim(length=1, time=-1)

# Named quantity types of the language, in the order they are preferred when printing a dimension.
NAMED_DIMS: dict[str, Dim] = {
    "Real": DIMENSIONLESS,
    "Length": LENGTH,
    "Angle": ANGLE,
    "Mass": MASS,
    "Time": TIME,
    "Force": FORCE,
}

# Unit suffix -> (dimension, factor to SI).
UNITS: dict[str, tuple[Dim, float]] = {
    "m": (LENGTH, 1.0),
    "cm": (LENGTH, 0.01),
    "mm": (LENGTH, 0.001),
    "rad": (ANGLE, 1.0),
    "deg": (ANGLE, math.pi / 180.0),
    "kg": (MASS, 1.0),
    "g": (MASS, 0.001),
    "s": (TIME, 1.0),
    "ms": (TIME, 0.001),
    "N": (FORCE, 1.0),
}

_SYMBOLS = ("m", "rad", "kg", "s")  # SI symbol per base dimension, for printing compound dims


def dim_name(dim: Dim) -> str:
    """The language's name for a dimension, e.g. `Length`, `Length / Time`, `Real`.

    >>> dim_name(Dim(length=1, time=-1))
    'Length / Time'
    >>> dim_name(Dim(length=2))
    'Length^2'
    """
    for name, named in NAMED_DIMS.items():
        if named == dim:
            return name
    names = ("Length", "Angle", "Mass", "Time")
    num = [_power(n, e) for n, e in zip(names, dim.exponents, strict=True) if e > 0]
    den = [_power(n, -e) for n, e in zip(names, dim.exponents, strict=True) if e < 0]
    text = " * ".join(num) if num else "Real"
    if den:
        text += " / " + (den[0] if len(den) == 1 else "(" + " * ".join(den) + ")")
    return text


def _power(name: str, exponent: int) -> str:
    return name if exponent == 1 else f"{name}^{exponent}"


def si_unit(dim: Dim) -> str:
    """SI unit text of a dimension, e.g. `m/s`; empty for dimensionless."""
    num = [_power(s, e) for s, e in zip(_SYMBOLS, dim.exponents, strict=True) if e > 0]
    den = [_power(s, -e) for s, e in zip(_SYMBOLS, dim.exponents, strict=True) if e < 0]
    text = "*".join(num) or ("1" if den else "")
    return text + ("/" + "/".join(den) if den else "")


_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z]*)\s*$")


def parse_quantity(text: str) -> tuple[float, Dim]:
    """Parse `3cm`, `30deg`, `0.3kg` or `2` into (SI value, dimension).

    Raises ValueError with a readable message for anything else.

    >>> parse_quantity("3cm")
    (0.03, Dim(length=1, angle=0, mass=0, time=0))
    """
    match = _QUANTITY.match(text)
    if not match:
        raise ValueError(f"`{text}` is not a number with an optional unit such as `3cm` or `30deg`")
    value, unit = float(match.group(1)), match.group(2)
    if not unit:
        return value, DIMENSIONLESS
    if unit not in UNITS:
        known = ", ".join(UNITS)
        raise ValueError(f"unknown unit `{unit}` in `{text}`; known units: {known}")
    dim, factor = UNITS[unit]
    return value * factor, dim
