"""CasADi versions of the registry entries marked `symbolic`, for `solve ... minimize ... subject`.

The executor lowers a `solve` block to `casadi.Opti`: the decision variable is an MX 3x1 vector,
entity-dependent builtins are evaluated numerically first (rapid_dsl.runtime.builtins) and enter as
constants through `constant`. Every entry here is `impl(*args)` (no frames) and accepts casadi
MX/SX/DM as plain floats and numpy arrays; vectors are 3x1 columns. With only numeric
arguments the result is a float or a DM.

Solver: casadi's bundled ipopt works here (`opti.solver("ipopt", ...)`); tests/runtime/
test_symbolic.py builds and solves a small problem with these builtins.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

# norm is smoothed as sqrt(|v|^2 + NORM_EPS^2) so that its gradient exists at v = 0, where a
# `minimize norm(d)` problem usually starts; the value changes by at most NORM_EPS (1 micrometre).
NORM_EPS = 1e-6

UP = ca.DM([0.0, 0.0, 1.0])

Sym = Any  # casadi MX / SX / DM, float or numpy array


def constant(value: Any) -> float | ca.DM:
    """A numeric builtin result as a solve constant: (1, 1) or scalar -> float, (1, 1, 3) -> DM 3x1.

    Raises ValueError when the value still varies over samples or time (a solve runs per state).
    """
    array = np.asarray(value, dtype=float)
    if array.size == 1:
        return float(array.reshape(()))
    if array.shape[-1] == 3 and array.size == 3:
        return ca.DM(array.reshape(3))
    raise ValueError(f"a solve constant must be one scalar or one 3-vector, got shape "
                     f"{array.shape}")


def vec(x: Sym, y: Sym, z: Sym) -> Sym:
    """A 3x1 vector from three scalars (vector literals)."""
    return ca.vertcat(x, y, z)


def component(v: Sym, i: int) -> Sym:
    """`v.x`, `v.y`, `v.z` for i = 0, 1, 2."""
    return _column(v)[i]


def _column(v: Sym) -> Sym:
    """Numpy vectors become DM 3x1 columns; casadi values pass through."""
    if isinstance(v, (ca.MX, ca.SX, ca.DM)):
        return v
    return ca.DM(np.asarray(v, dtype=float).reshape(3))


def norm(v: Sym) -> Sym:
    v = _column(v)
    return ca.sqrt(ca.sumsqr(v) + NORM_EPS**2)


def dot(a: Sym, b: Sym) -> Sym:
    return ca.dot(_column(a), _column(b))


def cross(a: Sym, b: Sym) -> Sym:
    return ca.cross(_column(a), _column(b))


def normalize(v: Sym) -> Sym:
    v = _column(v)
    return v / norm(v)


def clamp(x: Sym, lo: Sym, hi: Sym) -> Sym:
    return ca.fmin(ca.fmax(x, lo), hi)


def horizontal(v: Sym) -> Sym:
    v = _column(v)
    return ca.vertcat(v[0], v[1], 0)


SYMBOLIC: dict[str, Callable[..., Any] | Any] = {
    "abs": ca.fabs,
    "min": ca.fmin,
    "max": ca.fmax,
    "clamp": clamp,
    "sqrt": ca.sqrt,
    "sin": ca.sin,
    "cos": ca.cos,
    "atan2": ca.atan2,
    "norm": norm,
    "dot": dot,
    "cross": cross,
    "normalize": normalize,
    "horizontal": horizontal,
    "up": UP,
    "pi": math.pi,
}
