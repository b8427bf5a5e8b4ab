"""Binding roles to scene entities under relations, ranking the bindings, and explaining when
nothing binds or why an entity was rejected."""

from __future__ import annotations

import numpy as np
import pytest
from frames_factory import Body, make_frames, quat_about, tabletop
from hypothesis import given, settings
from hypothesis import strategies as st

from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.runtime import binding as binding_module
from rapid_dsl.runtime.binding import (
    BindingBudgetError,
    BindingError,
    Problem,
    bind,
    explain_no_binding,
)
from rapid_dsl.runtime.evidence import evidence, parse_call
from rapid_dsl.runtime.ranking import rank
from rapid_dsl.runtime.similarity import similarity, words

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


# ------------------------------------------------------------------------ the floor, ranking

FLOOR = Body("floor", "Surface", (20.0, 20.0, 0.0), (0.0, 0.0, -0.75), shape="plane")


def test_the_floor_never_fills_a_fixture_role_but_stays_a_surface():
    frames = _scene(floor=FLOOR)
    walls = bind([("box", "Object"), ("wall", "Fixture")], [], frames)
    assert {b["wall"] for b in walls} == {"table", "wall"}
    supports = bind([("s", "Surface")], [], frames)
    assert [b["s"] for b in supports] == ["table", "floor"]
    assert bind([("b", "Body")], [], frames, fixed={"b": "floor"}) == [{"b": "floor"}]
    with pytest.raises(BindingError, match=r"--bind wall=floor: `floor` is a plane \(the floor\)"
                                           r": a Surface only, with no side face for Fixture"):
        bind([("wall", "Fixture")], [], frames, fixed={"wall": "floor"})
    lone = make_frames([*tabletop()[1:], FLOOR])       # gripper and floor only
    assert "the floor is a Surface only" in explain_no_binding([("wall", "Fixture")], [], lone)


def _crates(*labels: str):
    """Boxes c0, c1, ... with the given labels, all on the table."""
    crates = {f"c{i}": Body(f"c{i}", "Object", (0.1, 0.1, 0.04), (0.3 + 0.15 * i, 0.0, 0.02),
                            label=label) for i, label in enumerate(labels)}
    return make_frames(tabletop(**crates), contacts=[(n, "table") for n in crates])


CRATE_ROLES = [("box", "Object"), ("table", "Surface")]
ON = [("on", ("box", "table"))]


def test_ranking_prefers_the_label_that_matches_the_role_then_the_hint():
    frames = _crates("crate", "Cereal-Box", "red crate")
    ranking = rank(CRATE_ROLES, ON, frames)
    assert [c.binding["box"] for c in ranking.candidates] == ["c1", "c0", "c2"]
    assert ranking.status() == "best" and ranking.best is ranking.candidates[0]
    assert ranking.candidates[0].scores == {"box": 1.0, "table": 1.0}
    hinted = rank(CRATE_ROLES, ON, frames, hints={"box": "the red one"})
    assert hinted.candidates[0].binding["box"] == "c2"
    # bind() returns the same order.
    assert [b["box"] for b in bind(CRATE_ROLES, ON, frames)] == ["c1", "c0", "c2"]


def test_equal_scores_are_ambiguous_whatever_the_alternatives():
    ranking = rank(CRATE_ROLES, ON, _crates("crate", "crate"))
    assert ranking.ambiguous and ranking.best is None and ranking.status() == "ambiguous"
    assert ranking.count == "2 bindings"
    single = rank(CRATE_ROLES, ON, _crates("crate"))
    assert single.status() == "unique" and single.count == "1 binding"


def test_fewest_alternatives_break_score_ties():
    # No name matches (all scores 0). The relation allows (a0, w0), (a1, w0) and (a1, w1):
    # (a1, w0) has two one-role variants, the others one each, so it ranks last.
    frames = make_frames(tabletop(
        a0=Body("a0", "Object", (0.05, 0.05, 0.05), (0.3, 0.0, 0.025)),
        a1=Body("a1", "Object", (0.05, 0.05, 0.05), (0.6, 0.0, 0.025)),
        w0=Body("w0", "Fixture", (0.02, 0.2, 0.1), (0.7, 0.2, 0.05)),
        w1=Body("w1", "Fixture", (0.02, 0.2, 0.1), (0.7, -0.2, 0.05)),
    ))
    names = [e.name for e in frames.entities.entities]
    allowed = {("a0", "w0"), ("a1", "w0"), ("a1", "w1")}

    def pair(frames, o, f):
        return np.full((1, 1), (names[o], names[f]) in allowed)

    ranked = rank([("o", "Object"), ("f", "Fixture")], [("pair", ("o", "f"))], frames,
                  relations={"pair": pair}).candidates
    assert [(c.binding["o"], c.binding["f"], c.alternatives) for c in ranked] == [
        ("a0", "w0", 1), ("a1", "w1", 1), ("a1", "w0", 2)]


def test_the_count_says_when_the_search_stopped(monkeypatch):
    monkeypatch.setattr(binding_module, "ENUMERATION_CAP", 3)
    ranking = rank([("o", "Object")], [], _crates("a", "b", "c", "d"))
    assert len(ranking.candidates) == 3 and not ranking.complete
    assert ranking.count == "more than 3 bindings"
    assert ranking.to_json()["complete"] is False


def test_rejections_name_the_first_false_relation_with_its_value():
    frames = _scene()
    ranking = rank(ROLES, REQUIRES, frames)
    assert [c.binding for c in ranking.candidates] == [
        {"box": "box", "table": "table", "wall": "wall", "hand": "gripper"}]
    reasons = {(r.role, r.entity): r for r in ranking.rejections}
    cube = reasons["box", "cube"]
    assert cube.requirement == "on(box, table)"
    assert cube.reason == ("on(box, table) is false (the bottom of cube is 0.175 m from the top "
                           "of table, more than 0.01 m)")
    # The first requirement false for every choice of the other roles comes first ...
    assert reasons["wall", "table"].reason == (
        "faces(wall, box) is false for every choice of box (not level: box spans z 0..0.03 m, "
        "table z -0.04..0 m)")
    # ... else the role that cannot do without the entity.
    unfaced = {(r.role, r.entity): r.reason for r in rank(ROLES, REQUIRES[:1], frames).rejections}
    assert unfaced["wall", "table"] == "`table` is the only entity role `table` can take"
    # A relation that fails only with the best binding's other entities says which.
    far = _scene(far=Body("far", "Fixture", (0.02, 0.4, 0.3), (0.2, -0.45, 0.15)))
    rejected = {(r.role, r.entity): r for r in rank(ROLES, REQUIRES, far).rejections}
    assert rejected["wall", "far"].text.startswith("wall=far: faces(wall, box) is false")


def test_kind_mismatches_are_reported_only_for_entities_that_look_expected():
    frames = _scene(wall2=Body("wall_2", "Object", (0.05, 0.05, 0.05), (0.2, -0.3, 0.025)))
    rejected = {(r.role, r.entity): r.reason for r in rank(ROLES, [], frames).rejections}
    assert rejected["wall", "wall_2"] == "`wall_2` is of kind Object, role `wall` needs Fixture"
    assert ("wall", "gripper") not in rejected and ("box", "table") not in rejected


def test_every_builtin_relation_has_evidence():
    relations = {name for name, b in BUILTINS.items() if b.kind == "relation"}
    frames = _scene()
    for name in relations:
        arity = len(BUILTINS[name].params)
        assert parse_call(f"{name}({', '.join(['x'] * arity)})") is not None, name
    assert evidence(frames, "touching", (2, 3)) == "distance 0.19 m"    # box .. wall
    assert evidence(frames, "touching", (2, 0)) is None                 # they touch
    assert evidence(frames, "reachable", (1, 4)) is None
    assert evidence(frames, "upright", (4,)) is None
    assert parse_call("not touching(a, b)") is None and parse_call("distance(a, b)") is None


@pytest.mark.slow
@given(st.lists(st.sampled_from(["box", "crate", "Box", "cereal box", "red_crate", "wall", "",
                                 "table top", "boxes"]), min_size=1, max_size=5),
       st.sampled_from(["box", "crate", "top", "o"]))
def test_ranking_is_bind_e_in_score_order(labels, role):
    frames = _crates(*labels)
    roles = [(role, "Object"), ("table", "Surface")]
    on = [("on", (role, "table"))]
    problem = Problem(roles, on, frames, {}, {})
    everything = sorted(problem.search())
    ranked = rank(roles, on, frames).candidates
    assert sorted(tuple(frames.entities.index(c.binding[n]) for n, _ in roles)
                  for c in ranked) == everything
    assert [c.score for c in ranked] == sorted((c.score for c in ranked), reverse=True)
    assert all(0.0 <= similarity(label, label) <= 1.0 for label in labels)
    assert all(similarity(w, w) == 1.0 for w in labels if words(w))


# ------------------------------------------------------------------- search order and budget

def _boxes(count: int):
    """`count` small boxes on the table, 10 cm apart: no two within 1 mm of each other."""
    boxes = {f"b{i}": Body(f"b{i}", "Object", (0.03, 0.03, 0.03),
                           (0.1 * (i % 8), -0.4 + 0.1 * (i // 8), 0.015)) for i in range(count)}
    return make_frames(tabletop(**boxes), contacts=[(n, "table") for n in boxes])


def _near(frames, a, b):
    from rapid_dsl.runtime.builtins import distance
    return distance(frames, a, b) < 0.001


FIVE = [(f"o{i}", "Object") for i in range(1, 6)]


def test_a_relation_prunes_as_soon_as_its_roles_are_filled_whatever_their_order():
    # `near(o5, o1)` names the first and the last role: o5 is filled right after o1, so the
    # search tries 62 x 61 pairs instead of 62 x 61 x 60 x 59 x 58 assignments.
    problem = Problem(FIVE, [("near", ("o5", "o1"))], _boxes(62), {}, {"near": _near})
    assert [problem.roles[p][0] for p in problem.order[:2]] == ["o1", "o5"]
    assert list(problem.search()) == []
    # every candidate tried is a step, one already taken too; only distinct pairs are evaluated
    assert problem.steps == 62 + 62 * 62 and problem.evaluations == 62 * 61
    reason = problem.explain()
    assert reason.startswith("no binding: near(o5, o1) is false for every candidate: "
                             "(o5=b5, o1=b1)")
    assert reason.endswith("and 3778 more")


def test_pinned_and_single_candidate_roles_are_filled_first():
    roles = [("box", "Object"), ("table", "Surface"), ("hand", "Manipulator")]
    problem = Problem(roles, [("on", ("box", "table"))], _scene(floor=FLOOR), {"box": "cube"}, {})
    assert [len(problem.candidates[name]) for name, _ in roles] == [1, 2, 1]
    assert [problem.roles[p][0] for p in problem.order] == ["box", "hand", "table"]


def test_a_search_past_its_budget_says_how_large_it_is_and_to_pin_roles():
    frames = _crates(*["crate"] * 30)
    never = {"apart": lambda frames, *entities: np.zeros((1, 1), dtype=bool)}
    spans = [("apart", ("o1", "o2", "o3", "o4", "o5"))]   # checked only once all five are filled
    with pytest.raises(BindingBudgetError) as raised:
        rank(FIVE, spans, frames, relations=never)
    assert str(raised.value) == (
        "binding the roles takes more than 10,000 relation evaluations, the limit: candidates "
        "per role: o1 30, o2 30, o3 30, o4 30, o5 30 (24,300,000 assignments); pin roles with "
        "--bind role=entity to narrow the search")
    assert isinstance(raised.value, BindingError)     # bad input to the command line: exit 2
    pinned = rank(FIVE, spans, frames, relations=never, fixed={"o1": "c0", "o2": "c1", "o3": "c2"})
    assert pinned.candidates == () and "apart(o1, o2, o3, o4, o5) is false for every candidate" \
        in (pinned.reason or "")


def test_partial_bindings_count_too(monkeypatch):
    # Without relations nothing is evaluated; the steps bound the search by themselves.
    monkeypatch.setattr(binding_module, "MAX_BINDING_STEPS", 1000)
    with pytest.raises(BindingBudgetError, match=r"more than 1,000 steps \(partial bindings "
                                                 r"tried\), the limit: candidates per role: o1 30"):
        rank(FIVE, [], _crates(*["crate"] * 30))


def test_too_few_entities_for_many_roles_is_found_without_trying_assignments():
    # 12 roles for 11 objects: trying every assignment would take 11! steps.
    roles = [(f"o{i}", "Object") for i in range(12)]
    problem = Problem(roles, [], _boxes(11), {}, {})
    assert problem.explain().startswith("no binding: the scene has too few distinct entities")
    assert problem.steps == 0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["Object", "Surface", "Fixture", "Body", "Manipulator"]),
                min_size=1, max_size=4),
       st.lists(st.tuples(st.lists(st.integers(0, 3), min_size=1, max_size=3),
                          st.integers(0, 2**32 - 1)), max_size=3),
       st.dictionaries(st.integers(0, 3), st.sampled_from(["table", "box", "cube", "wall"]),
                       max_size=1))
def test_the_pruned_search_finds_exactly_the_brute_force_bindings(kinds, clauses, pins):
    from itertools import product

    frames = _scene()
    roles = [(f"r{i}", kind) for i, kind in enumerate(kinds)]
    requires, relations = [], {}
    for k, (positions, seed) in enumerate(clauses):
        args = tuple(roles[p % len(roles)][0] for p in positions)

        def holds(frames, *entities, seed=seed):   # a fixed pseudo-random truth table
            return np.full((1, 1), hash((seed, entities)) % 3 != 0)
        requires.append((f"rel{k}", args))
        relations[f"rel{k}"] = holds
    fixed = {roles[p % len(roles)][0]: name for p, name in pins.items()}
    try:
        problem = Problem(roles, requires, frames, fixed, relations)
    except BindingError:
        return   # a pin of the wrong kind
    pools = [problem.candidates[name] for name, _ in roles]
    position = {name: i for i, (name, _) in enumerate(roles)}
    expected = sorted(
        choice for choice in product(*pools) if len(set(choice)) == len(choice)
        and all(relations[rel](frames, *(choice[position[a]] for a in args))[0, 0]
                for rel, args in requires))
    assert sorted(problem.search()) == expected
    assert bool(expected) == (next(iter(bind(roles, requires, frames, fixed=fixed,
                                             relations=relations)), None) is not None)
