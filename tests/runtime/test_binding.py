"""Binding roles to scene entities under relations, and explaining when nothing binds."""

from __future__ import annotations

import numpy as np
import pytest
from frames_factory import Body, make_frames, quat_about, tabletop

from rapid_dsl.runtime.binding import BindingError, bind, explain_no_binding

ROLES = [("box", "Object"), ("table", "Surface"), ("wall", "Fixture"), ("hand", "Manipulator")]
REQUIRES = [("on", ("box", "table")), ("faces", ("wall", "box")), ("reachable", ("hand", "wall"))]


def _scene(**extra: Body):
    """Entities in order: table, gripper, box (on the table by the wall), wall, cube (in air)."""
    bodies = tabletop(
        box=Body("box", "Object", (0.2, 0.14, 0.03), (0.5, 0.0, 0.015)),
        wall=Body("wall", "Fixture", (0.02, 0.4, 0.3), (0.8, 0.0, 0.15)),
        cube=Body("cube", "Object", (0.05, 0.05, 0.05), (0.3, 0.3, 0.2)),
        **extra,
    )
    return make_frames(bodies, contacts=[("box", "table")])


def test_binds_the_only_scene_reading_that_satisfies_the_relations():
    assert bind(ROLES, REQUIRES, _scene()) == [
        {"box": "box", "table": "table", "wall": "wall", "hand": "gripper"}]


def test_without_relations_every_injective_typed_assignment_in_entity_order():
    found = bind(ROLES, [], _scene())
    # Surface <: Fixture, so the table could fill `wall`, but it is taken by `table` (injective).
    assert found == [
        {"box": "box", "table": "table", "wall": "wall", "hand": "gripper"},
        {"box": "cube", "table": "table", "wall": "wall", "hand": "gripper"},
    ]
    assert bind([("f", "Fixture"), ("o", "Object")], [], _scene(), limit=3) == [
        {"f": "table", "o": "box"}, {"f": "table", "o": "cube"}, {"f": "wall", "o": "box"}]


def test_order_follows_entities_and_two_candidates_both_bind():
    twin = Body("twin", "Object", (0.1, 0.1, 0.03), (0.55, -0.15, 0.015))
    frames = make_frames(tabletop(box=Body("box", "Object", (0.1, 0.1, 0.03), (0.5, 0.1, 0.015)),
                                  twin=twin), contacts=[("box", "table"), ("twin", "table")])
    found = bind([("o", "Object"), ("s", "Surface")], [("on", ("o", "s"))], frames)
    assert [b["o"] for b in found] == ["box", "twin"]
    pinned = bind([("o", "Object"), ("s", "Surface")], [("on", ("o", "s"))], frames,
                  fixed={"o": "twin"})
    assert pinned == [{"o": "twin", "s": "table"}]


def test_relations_are_checked_in_the_given_state():
    tipped = _scene(tipped=Body("tipped", "Object", (0.1, 0.1, 0.1), (0.3, -0.3, 0.05),
                                quat_about([1, 0, 0], 0.5)))
    found = bind([("o", "Object")], [("upright", ("o",))], tipped)
    assert [b["o"] for b in found] == ["box", "cube"]


def test_custom_relation_implementations_take_part():
    def low(frames, o):
        return frames.pos[:, :, o, 2] < 0.1
    found = bind([("o", "Object")], [("low", ("o",))], _scene(), relations={"low": low})
    assert found == [{"o": "box"}]


@pytest.mark.parametrize("fixed, message", [
    ({"lid": "box"}, "no role `lid`"),
    ({"box": "lid"}, "no entity `lid`"),
    ({"box": "wall"}, "`wall` is of kind Fixture, role `box` needs Object"),
])
def test_bad_pins_are_reported(fixed, message):
    with pytest.raises(BindingError, match=message):
        bind(ROLES, REQUIRES, _scene(), fixed=fixed)


def test_malformed_requirements_are_reported():
    with pytest.raises(BindingError, match="`near` is not a relation"):
        bind(ROLES, [("near", ("box", "wall"))], _scene())
    with pytest.raises(BindingError, match="unknown role"):
        bind(ROLES, [("on", ("box", "floor"))], _scene())
    with pytest.raises(BindingError, match="takes 2 argument"):
        bind(ROLES, [("on", ("box",))], _scene())
    with pytest.raises(BindingError, match="unknown kind `Thing`"):
        bind([("x", "Thing")], [], _scene())


def test_explains_roles_that_compete_for_too_few_entities():
    # The table is the only Fixture (Surface <: Fixture) but `table` already needs it.
    frames = make_frames(tabletop(box=Body("box", "Object", (0.1, 0.1, 0.1), (0.5, 0, 0.05))))
    assert bind(ROLES, REQUIRES, frames) == []
    assert explain_no_binding(ROLES, REQUIRES, frames) == (
        "no binding: the scene has too few distinct entities for the roles "
        "(box: Object, table: Surface, wall: Fixture, hand: Manipulator)")


def test_explains_a_relation_false_for_all_candidates():
    frames = make_frames(tabletop(box=Body("box", "Object", (0.1, 0.1, 0.1), (0.5, 0, 0.05))))
    roles = [("box", "Object"), ("wall", "Fixture"), ("hand", "Manipulator")]
    assert explain_no_binding(roles, [("faces", ("wall", "box"))], frames) == (
        "no binding: faces(wall, box) is false for every candidate: (wall=table, box=box)")


def test_explains_which_relation_fails_for_whom():
    frames = _scene()
    reason = explain_no_binding(ROLES, REQUIRES, frames, fixed={"box": "cube"})
    assert bind(ROLES, REQUIRES, frames, fixed={"box": "cube"}) == []
    assert "on(box, table) is false for every candidate: (box=cube, table=table)" in reason
    # Candidates are quoted best match first: `wall` for role `wall`.
    assert ("faces(wall, box) is false for every candidate: (wall=wall, box=cube), "
            "(wall=table, box=cube)") in reason
    no_manipulator = explain_no_binding([("o", "Object"), ("m", "Manipulator")], [],
                                        make_frames(tabletop()[:1]))
    assert "role `o: Object` has no candidate (the scene has no entity of kind Object)" in \
        no_manipulator
    lonely = make_frames(tabletop(box=Body("box", "Object", (1, 1, 1), (0, 0, 0))))
    too_few = explain_no_binding([("a", "Object"), ("b", "Object")], [], lonely)
    assert too_few == "no binding: the scene has too few distinct entities for the roles " \
        "(a: Object, b: Object)"


def test_explains_relations_that_cannot_hold_together():
    # The box is on the table but sliding; the cube is still but in the air.
    frames = make_frames(tabletop(
        box=Body("box", "Object", (0.2, 0.14, 0.03), (0.5, 0.0, 0.015), linvel=(0.2, 0, 0)),
        cube=Body("cube", "Object", (0.05, 0.05, 0.05), (0.3, 0.3, 0.2)),
    ), contacts=[("box", "table")])
    roles = [("o", "Object"), ("s", "Surface")]
    requires = [("on", ("o", "s")), ("settled", ("o",))]
    assert bind(roles, requires, frames) == []
    reason = explain_no_binding(roles, requires, frames)
    assert "no single injective assignment satisfies all of them together" in reason
    assert "on(o, s) holds only for (o=box, s=table)" in reason
    assert "settled(o) holds only for (o=cube)" in reason


def test_binding_many_entities_is_fast_and_deterministic():
    rng = np.random.default_rng(4)
    clutter = {f"o{i}": Body(f"o{i}", "Object", (0.05, 0.05, 0.05),
                             (*rng.uniform([0.1, -0.4], [0.7, 0.4]), 0.025)) for i in range(12)}
    frames = make_frames(tabletop(**clutter))
    roles = [("a", "Object"), ("b", "Object"), ("s", "Surface"), ("m", "Manipulator")]
    requires = [("on", ("a", "s")), ("on", ("b", "s")), ("reachable", ("m", "a"))]
    first = bind(roles, requires, frames)
    assert len(first) == 12 * 11
    assert first == bind(roles, requires, frames)
    assert first[0] == {"a": "o0", "b": "o1", "s": "table", "m": "gripper"}
