"""CasADi builtins agree with the numpy ones and drive a real `solve` problem."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from frames_factory import Body, make_frames

from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.runtime import symbolic as S
from rapid_dsl.runtime.builtins import IMPLEMENTATIONS
from rapid_dsl.runtime.symbolic import SYMBOLIC

FRAMES = make_frames([Body("b", "Object", (1, 1, 1), (0, 0, 0))])
VECTOR_PARAMS = {"norm", "dot", "cross", "normalize", "horizontal"}


def test_symbolic_covers_exactly_the_symbolic_registry_entries():
    assert set(SYMBOLIC) == {name for name, b in BUILTINS.items() if b.symbolic}


def _arguments(name, rng):
    if name in VECTOR_PARAMS:
        return [rng.normal(size=3) for _ in BUILTINS[name].params]
    return [float(rng.uniform(0.2, 2.0)) for _ in BUILTINS[name].params]


@pytest.mark.parametrize("name", sorted(n for n, b in BUILTINS.items()
                                        if b.symbolic and b.kind == "function"))
def test_symbolic_matches_numpy_on_numbers_and_on_mx(name):
    rng = np.random.default_rng(3)
    args = _arguments(name, rng)
    expected = np.asarray(IMPLEMENTATIONS[name](FRAMES, *args), dtype=float).ravel()
    numeric = np.asarray(ca.DM(SYMBOLIC[name](*args))).ravel()
    np.testing.assert_allclose(numeric, expected, rtol=1e-9, atol=1e-9)
    # The same builtin on symbols, evaluated through a casadi Function.
    symbols = [ca.MX.sym(f"a{i}", 3 if name in VECTOR_PARAMS else 1) for i in range(len(args))]
    function = ca.Function("f", symbols, [SYMBOLIC[name](*symbols)])
    through = np.asarray(function(*args)).ravel()
    np.testing.assert_allclose(through, expected, rtol=1e-9, atol=1e-9)


def test_constants_and_helpers():
    np.testing.assert_array_equal(np.asarray(SYMBOLIC["up"]).ravel(), [0, 0, 1])
    assert SYMBOLIC["pi"] == pytest.approx(np.pi)
    assert S.constant(np.array([[0.25]])) == 0.25
    assert S.constant(np.array([[[1.0, 2.0, 3.0]]])).shape == (3, 1)
    with pytest.raises(ValueError, match="one scalar or one 3-vector"):
        S.constant(np.zeros((2, 1, 3)))
    d = ca.MX.sym("d", 3)
    assert float(ca.Function("f", [d], [S.component(S.vec(d[2], 1.0, 0.0), 0)])([0, 0, 7])) == 7.0


def test_solve_minimal_displacement_with_ipopt():
    """`solve d: Point minimize norm(d) / 1cm subject { (p + d).x > c + 5cm; (p + d).z == p.z }`."""
    p = S.constant(np.array([[[0.5, 0.1, 0.02]]]))   # pos(box), evaluated numerically first
    c = 0.7                                           # pos(wall).x
    opti = ca.Opti()
    d = opti.variable(3)
    opti.minimize(SYMBOLIC["norm"](d) / 0.01)
    opti.subject_to(S.component(p + d, 0) > c + 0.05)
    opti.subject_to(S.component(p + d, 2) == S.component(p, 2))
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes"})
    solution = opti.solve()
    assert solution.stats()["success"]
    np.testing.assert_allclose(solution.value(d), [0.25, 0.0, 0.0], atol=1e-6)
