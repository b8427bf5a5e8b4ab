"""`solve v: T minimize J subject {...}` at run time: one small casadi.Opti problem per argument.

Compiled code evaluates every entity-dependent part numerically first (numpy builtins on the
current state), turns it into a constant with `constant`, and builds the objective and constraints
from `SYMBOLIC` builtins and casadi arithmetic on the decision variable. Imported only by programs
that contain a `solve`, so casadi stays out of the others.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import casadi as ca
import numpy as np

from rapid_dsl.runtime.symbolic import SYMBOLIC, component, constant, vec

# The registry's CasADi implementations under their registry names: `SYMBOLIC_NS.norm(d)`.
SYMBOLIC_NS = SimpleNamespace(**SYMBOLIC)

__all__ = ["SYMBOLIC_NS", "Problem", "SolveError", "component", "constant", "vec"]

# Quiet: a failed solve is reported by its status; CasADi's per-evaluation warnings ("Inf detected
# for output f", dozens per solve of `d.x == 1e300m`) would only flood stderr.
_IPOPT: dict[str, bool | int | float | str] = {
    "print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.max_iter": 500,
    "ipopt.tol": 1e-9, "show_eval_warnings": False}


class SolveError(RuntimeError):
    """The solver found no feasible optimum; the message says what it reported."""


class Problem:
    """One decision variable (a scalar, or a 3-vector for Point/Direction/Vec types)."""

    def __init__(self, name: str, size: int) -> None:
        self.name = name
        self.size = size
        self._opti = ca.Opti()
        self.var = self._opti.variable(size)
        self._opti.set_initial(self.var, 0.0)
        self._objective: Any = None

    def minimize(self, objective: Any) -> None:
        self._objective = objective
        self._opti.minimize(objective)

    def subject(self, constraint: Any) -> None:
        self._opti.subject_to(constraint)

    def solve(self) -> float | np.ndarray:
        """The optimum: a float for a scalar variable, (3,) for a vector. Raises SolveError."""
        self._opti.solver("ipopt", _IPOPT)
        try:
            solution = self._opti.solve()
        except RuntimeError as exc:
            status = self._opti.stats().get("return_status", str(exc).splitlines()[-1])
            raise SolveError(f"solve for `{self.name}` failed: {status}") from None
        value = np.asarray(solution.value(self.var), dtype=float).reshape(-1)
        return float(value[0]) if self.size == 1 else value
