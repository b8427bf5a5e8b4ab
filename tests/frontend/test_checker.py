"""One test per checker rule: which codes a small program gets (the goldens pin the wording)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rapid_dsl.frontend import ir
from rapid_dsl.frontend.driver import CheckResult, check_text
from rapid_dsl.frontend.types import Quantity, VecType
from rapid_dsl.language.units import Dim

STUBS = Path(__file__).parent.parent / "data" / "stub_stdlib"


def check(text: str, path: str = "t.rapid", **kw: object) -> CheckResult:
    return check_text(text, path, stdlib=STUBS, **kw)  # type: ignore[arg-type]


def codes(text: str, **kw: object) -> list[str]:
    return [d.code for d in check(text, **kw).diagnostics]


def prim(success: str = "touching(hand, target)", cost: str = "distance(hand, target) / 1cm",
         extra: str = "", roles: str = "target: Object, hand: Manipulator",
         motion: str = "keypoint reach = pos(target)") -> str:
    return (f'primitive p {{\n  goal "g"\n  roles {{ {roles} }}\n{extra}\n'
            f"  success {{ {success} }}\n  cost final = {cost}\n  motion {{ {motion} }}\n}}\n")


def feature_type(expr: str, extra: str = "") -> ir.Type:
    """The type the checker gives `expr` as a resolve entry of a small primitive."""
    result = check(prim(extra=f"  {extra}\n  resolve {{ v = {expr} }}"))
    assert result.program is not None, [d.message for d in result.diagnostics]
    return result.program.primitive("p").features[0].expr.type


HEAD = """use stdlib.{push, flip, grasp}
strategy s {
  goal "g"
  roles { box: Object, table: Surface, wall: Fixture, hand: Manipulator }
  requires { on(box, table); faces(wall, box); reachable(hand, wall) }
"""
TIP = "  phase tip: flip(target=box, support=table, fixture=wall, hand=hand)"


def strategy(body: str) -> str:
    return HEAD + body + "\n}\n"


# --------------------------------------------------------------------------- clean baseline

def test_minimal_primitive_is_clean() -> None:
    assert codes(prim()) == []


def test_minimal_strategy_is_clean() -> None:
    assert codes(strategy(TIP)) == []


# ------------------------------------------------------------------------- dimensions

@pytest.mark.parametrize(("expr", "expected"), [
    ("distance(hand, target)", Quantity(Dim(length=1))),
    ("speed(target)", Quantity(Dim(length=1, time=-1))),
    ("3cm * up", VecType(Dim(length=1))),
    ("up * 2", VecType(Dim())),
    ("norm(pos(target))", Quantity(Dim(length=1))),
    ("dot(pos(target), up)", Quantity(Dim(length=1))),
    ("dot(pos(target), pos(hand))", Quantity(Dim(length=2))),
    ("cross(pos(target), up)", VecType(Dim(length=1))),
    ("sqrt(distance(hand, target)^2 + 1cm^2)", Quantity(Dim(length=1))),
    ("atan2(1cm, 2cm)", Quantity(Dim(angle=1))),
    ("sin(30deg)", Quantity(Dim())),
    ("normalize(pos(target))", VecType(Dim())),
    ("clamp(height(target), 1cm, 2cm)", Quantity(Dim(length=1))),
    ("distance(hand, target)^-1", Quantity(Dim(length=-1))),
    ("pos(target) / 1s", VecType(Dim(length=1, time=-1))),
    ("pos(target).z", Quantity(Dim(length=1))),
    ("-pos(target)", VecType(Dim(length=1))),
    ("[1cm, 0cm, 2cm]", VecType(Dim(length=1))),
    ("if touching(hand, target) then 1cm else 2cm", Quantity(Dim(length=1))),
    ("pi * 2", Quantity(Dim())),
    ("10N / 1kg", Quantity(Dim(length=1, time=-2))),
    ("start(height(target))", Quantity(Dim(length=1))),
])
def test_types_of_expressions(expr: str, expected: ir.Type) -> None:
    assert feature_type(expr) == expected


def test_add_needs_one_dimension() -> None:
    assert codes(prim(success="3cm + 10deg > 0cm")) == ["E0301"]


def test_comparison_needs_one_dimension() -> None:
    result = check(prim(success="distance(hand, target) < 0.05"))
    [d] = result.diagnostics
    assert d.code == "E0302" and d.message == "cannot compare Length with Real"
    assert d.help == "give the bound a unit, e.g. `5cm`"


def test_comparison_of_angles_suggests_degrees() -> None:
    [d] = check(prim(success="tilt(target) < 10")).diagnostics
    assert d.code == "E0302" and d.help == "give the bound a unit, e.g. `10deg`"


def test_exponent_must_be_an_integer_literal() -> None:
    assert codes(prim(cost="(distance(hand, target) / 1cm)^2")) == []
    assert codes(prim(cost="(distance(hand, target) / 1cm)^0.5")) == ["E0304"]
    assert codes(prim(extra="  params { n: Real = 2 }",
                      cost="(distance(hand, target) / 1cm)^n")) == ["E0304"]


def test_sqrt_needs_even_exponents() -> None:
    assert codes(prim(success="sqrt(distance(hand, target)) > 1cm")) == ["E0317"]


def test_generic_builtin_arguments_share_a_dimension() -> None:
    assert codes(prim(success="max(height(target), 1deg) > 1cm")) == ["E0317"]


def test_trigonometry_takes_an_angle() -> None:
    assert codes(prim(success="sin(height(target)) > 0")) == ["E0303"]


def test_vectors_multiply_only_by_scalars() -> None:
    assert codes(prim(cost="norm(pos(hand) * pos(target))")) == ["E0309"]
    assert codes(prim(cost="1 / up")) == ["E0309"]


def test_vector_literal_needs_three_items_of_one_dimension() -> None:
    assert codes(prim(motion="keypoint k = [1cm, 2cm]")) == ["E0310"]
    assert codes(prim(motion="keypoint k = [1cm, 2cm, 3cm, 4cm]")) == ["E0310"]
    assert codes(prim(motion="keypoint k = [1cm, 2deg, 3cm]")) == ["E0311"]
    assert codes(prim(motion="keypoint k = [up, up, up]")) == ["E0311"]


def test_components_are_x_y_z_only() -> None:
    assert codes(prim(success="pos(target).z > 1cm")) == []
    assert codes(prim(success="pos(target).w > 1cm")) == ["E0306"]
    assert codes(prim(success="height(target).x > 1cm")) == ["E0312"]
    assert codes(prim(success="target.x > 1cm")) == ["E0312"]


def test_cost_must_be_dimensionless_with_the_documented_help() -> None:
    extra = ("  params { angle: Angle = 90deg }\n"
             "  resolve { turned = rotation(target, about=up) }")
    [d] = check(prim(extra=extra, cost="(turned - angle)^2")).diagnostics
    assert d.code == "E0308"
    assert d.help == ("cost must be dimensionless; divide by a scale, e.g. "
                      "`((turned - angle) / 10deg)^2`")
    assert codes(prim(extra=extra, cost="((turned - angle) / 10deg)^2")) == []
    assert codes(prim(cost="touching(hand, target)")) == ["E0308"]


def test_progress_cost_and_weight() -> None:
    ok = prim() + ""
    assert codes(ok.replace("  motion", "  cost progress weight 0.5 = height(hand) / 1cm\n"
                            "  motion")) == []
    assert codes(ok.replace("  motion", "  cost progress = height(hand)\n  motion")) == ["E0308"]
    assert codes(ok.replace("  motion", "  cost progress weight 1cm = height(hand) / 1cm\n"
                            "  motion")) == ["E0313"]
    assert codes(ok.replace("  motion", "  cost progress weight -1 = height(hand) / 1cm\n"
                            "  motion")) == ["E0406"]


# ------------------------------------------------------------------------------- Bool

@pytest.mark.parametrize("text", [
    prim(success="distance(hand, target)"),
    prim(extra="  requires { height(target) }"),
    prim(extra="  filter { 3cm }"),
    prim(success="if height(target) then true_ else false_"),
    prim(success="touching(hand, target) and height(target)"),
    prim(success="not height(target)"),
    "relation r(a: Body) = height(a)\n",
])
def test_bool_where_bool_is_needed(text: str) -> None:
    assert "E0307" in codes(text)


# ----------------------------------------------------------------------------- types

@pytest.mark.parametrize(("decl", "code"), [
    ("limit: Length / Time = 1cm / 1s", None),
    ("area: Length^2 = 1cm * 1cm", None),
    ("turns: Vec[Angle] = [1deg, 2deg, 3deg]", None),
    ("limit: Velocity = 1", "E0305"),
    ("limit: Vec = 1", "E0305"),
    ("limit: List[Length] = 1", "E0305"),
    ("limit: Vec[Object] = 1", "E0316"),
    ("limit: Object = 1", "E0316"),
    ("limit: Bool = 1", "E0316"),
    ("limit: Length * Object = 1", "E0316"),
    ("limit: Point^2 = 1", "E0316"),
])
def test_param_types(decl: str, code: str | None) -> None:
    found = codes(prim(extra=f"  params {{ {decl} }}"))
    assert found == ([code] if code else [])


def test_role_types_are_entity_kinds() -> None:
    assert codes(prim(roles="target: Length, hand: Manipulator")) == ["E0316"]


def test_subtyping_of_entity_arguments() -> None:
    # edge_axis wants (Object, Fixture, Surface); a Surface is also a Fixture.
    assert codes(prim(roles="target: Object, s: Surface, hand: Manipulator",
                      extra="  resolve { a = edge_axis(target, s, s) }")) == []
    assert codes(prim(roles="target: Body, s: Surface, hand: Manipulator",
                      extra="  resolve { a = edge_axis(target, s, s) }")) == ["E0303"]


# ---------------------------------------------------------------------------- calls

def test_keyword_and_positional_arguments() -> None:
    assert codes(prim(success="rotation(target, about=up) < 1deg")) == []
    assert codes(prim(success="rotation(about=up, b=target) < 1deg")) == []
    assert codes(prim(success="rotation(target, axis=up) < 1deg")) == ["E0507"]
    assert codes(prim(success="rotation(target, b=target, about=up) < 1deg")) == ["E0506"]
    assert codes(prim(success="rotation(target) < 1deg")) == ["E0505"]
    assert codes(prim(success="rotation(target, up, up) < 1deg")) == ["E0510"]
    assert codes(prim(success="rotation(about=up, target) < 1deg")) == ["E0511"]


def test_functions_are_not_values_and_values_are_not_functions() -> None:
    assert codes(prim(success="distance < 1cm")) == ["E0212"]
    assert codes(prim(success="target(hand)")) == ["E0212"]
    assert codes(prim(success="up() == up")) == ["E0212"]
    assert codes(prim(success="start < 1cm")) == ["E0212"]


def test_user_relations_and_defs() -> None:
    text = ("relation near(a: Body, b: Body) = distance(a, b) < 5cm\n"
            "def clearance(a: Body, b: Body) -> Length = distance(a, b) - 1cm\n"
            + prim(success="near(hand, target) and clearance(hand, target) < 2cm"))
    result = check(text)
    assert result.diagnostics == []
    assert result.program is not None
    clause = result.program.primitive("p").success[0].expr
    assert isinstance(clause, ir.Logic) and isinstance(clause.left, ir.UserCall)
    assert {f.name for f in result.program.functions} == {"near", "clearance"}


def test_def_body_must_match_its_type() -> None:
    assert codes("def d(a: Body) -> Length = height(a) / 1cm\n") == ["E0313"]
    assert codes("def d(a: Body) -> Bogus = height(a)\n") == ["E0305"]
    assert codes("relation r(a: Body, a: Body) = touching(a, a)\n") == ["E0202"]


def test_recursion_is_reported() -> None:
    text = ("def f(x: Length) -> Length = g(x)\n"
            "def g(x: Length) -> Length = f(x) + 1cm\n")
    assert codes(text) == ["E0214", "E0214"]


def test_declarations_cannot_take_reserved_or_constant_names() -> None:
    assert codes("def start(a: Body) -> Length = height(a)\n") == ["E0215"]
    assert codes(prim(extra="  params { up: Length = 1cm }")) == ["E0215"]


def test_primitives_and_strategies_may_take_builtin_names() -> None:
    """A builtin added to the registry must not break a program that already uses its name:
    primitives and strategies run only in phases, so they never meet builtins."""
    text = prim().replace("primitive p", "primitive spin") + \
        strategy("  phase twist: spin(target=box, hand=hand)").replace("strategy s", "strategy on")
    result = check(text, lint=True)
    assert [d.code for d in result.diagnostics if d.code != "W0101"] == []
    assert result.program is not None
    assert [s.phases[0].primitive for s in result.program.strategies] == ["spin"]


def test_a_def_that_shadows_a_builtin_is_a_warning_and_wins_in_its_file() -> None:
    text = ("def height(b: Body) -> Length = top(b) + 1cm\n"
            "relation on(a: Body, b: Body) = touching(a, b)\n"
            + prim(success="on(hand, target) and height(target) > 1cm"))
    assert codes(text) == []
    result = check(text, lint=True)
    assert [d.code for d in result.diagnostics] == ["W0109", "W0109"]
    assert result.program is not None
    clause = result.program.primitive("p").success[0].expr
    assert isinstance(clause, ir.Logic) and isinstance(clause.left, ir.UserCall)
    assert isinstance(clause.right, ir.Compare) and isinstance(clause.right.left, ir.UserCall)
    assert {f.name for f in result.program.functions} == {"height", "on"}


def test_primitive_is_not_a_function() -> None:
    assert codes("use stdlib.grasp\nrelation r(a: Object, m: Manipulator) = grasp(a, m)\n") \
        == ["E0213"]


# ---------------------------------------------------------------------------- scopes

def test_unknown_names_get_suggestions() -> None:
    [d] = check(prim(success="distance(hand, targt) < 1cm")).diagnostics
    assert d.code == "E0201" and "did you mean `target`?" in (d.help or "")


def test_duplicate_names_in_one_primitive() -> None:
    assert codes(prim(roles="target: Object, target: Object, hand: Manipulator")) == ["E0202"]
    assert codes(prim(extra="  params { hand: Length = 1cm }")) == ["E0202"]
    assert codes(prim(extra="  resolve { target = height(hand) }")) == ["E0202"]
    assert codes(prim(motion="keypoint hand = pos(target)")) == ["E0202"]


def test_features_use_only_earlier_features() -> None:
    ok = "  resolve {\n    a = height(target)\n    b = a + 1cm\n  }"
    bad = "  resolve {\n    b = a + 1cm\n    a = height(target)\n  }"
    assert codes(prim(extra=ok, success="b > 1cm")) == []
    assert codes(prim(extra=bad, success="b > 1cm")) == ["E0210"]
    assert codes(prim(extra="  resolve { a = a + 1cm }")) == ["E0210"]


def test_keypoints_use_only_earlier_keypoints() -> None:
    assert codes(prim(motion="keypoint a = pos(target); keypoint b = a + 1cm * up")) == []
    assert codes(prim(motion="keypoint b = a + 1cm * up; keypoint a = pos(target)")) \
        == ["E0210"]
    assert codes(prim(motion="keypoint a = pos(target)", success="a.z > 0cm")) == ["E0211"]


def test_keypoints_may_use_features_and_params() -> None:
    extra = "  params { lift: Length = 2cm }\n  resolve { h = height(target) }"
    assert codes(prim(extra=extra, success="h > lift",
                      motion="keypoint a = pos(target) + (h + lift) * up yaw yaw(target)")) == []


def test_requires_may_use_only_roles() -> None:
    assert codes(prim(extra="  params { lift: Length = 2cm }\n  requires { lift > 1cm }")) \
        == ["E0211"]
    assert codes(prim(extra="  resolve { h = height(target) }\n  requires { h > 1cm }")) \
        == ["E0211"]


def test_start_only_inside_primitives() -> None:
    assert codes(prim(success="height(target) - start(height(target)) > 1cm")) == []
    assert codes("relation r(a: Body) = start(height(a)) > 1cm\n") == ["E0209"]
    assert codes("def d(a: Body) -> Length = start(height(a))\n") == ["E0209"]
    assert codes(strategy(TIP + "\n  let h = start(height(box))")) == ["E0209"]
    assert codes(strategy(TIP + "\n  success { start(height(box)) > 1cm }")) == ["E0209"]
    assert codes(prim(success="start(height(target), 1) > 1cm")) == ["E0510"]


def test_solve_variable_exists_only_inside_its_solve() -> None:
    solve = ("  phase shove: push(target=box, support=table, hand=hand) {\n"
             "    displacement = solve d: Point minimize norm(d) / 1cm subject { d.z == 0cm }\n"
             "  }\n")
    assert codes(strategy(solve)) == []
    assert codes(strategy(solve + "  success { d.z > 0cm }")) == ["E0211"]


# ------------------------------------------------------------------------- blocks

@pytest.mark.parametrize(("drop", "block"), [
    ('  goal "g"\n', "goal"),
    ("  roles { target: Object, hand: Manipulator }\n", "roles"),
    ("  success { touching(hand, target) }\n", "success"),
    ("  cost final = distance(hand, target) / 1cm\n", "cost final"),
    ("  motion { keypoint reach = pos(target) }\n", "motion"),
])
def test_required_primitive_blocks(drop: str, block: str) -> None:
    text = prim().replace(drop, "")
    diagnostics = check(text).diagnostics
    missing = [d for d in diagnostics if d.code == "E0401"]
    assert len(missing) == 1 and f"`{block}`" in missing[0].message


def test_duplicate_blocks() -> None:
    assert codes(prim(extra='  goal "again"')) == ["E0402"]
    assert codes(prim(extra="  success { touching(hand, target) }")) == ["E0402"]
    assert codes(prim(extra="  optimize { samples 8 }\n  optimize { samples 8 }")) == ["E0402"]
    assert codes(prim(motion="keypoint a = pos(target); spread 1cm; spread 2cm")) == ["E0402"]


def test_at_least_one_manipulator_role() -> None:
    assert codes(prim(roles="target: Object, hand: Object")) == ["E0403"]


def test_motion_needs_a_keypoint_and_typed_settings() -> None:
    assert codes(prim(motion="duration 2s")) == ["E0404"]
    assert codes(prim(motion="keypoint a = up")) == ["E0313"]
    assert codes(prim(motion="keypoint a = pos(target) yaw 1cm")) == ["E0313"]
    assert codes(prim(motion="keypoint a = pos(target) pitch 0.5")) == ["E0313"]
    assert codes(prim(motion="keypoint a = pos(target) roll 3cm")) == ["E0313"]
    assert codes(prim(motion="keypoint a = pos(target); spread 1deg")) == ["E0313"]
    assert codes(prim(motion="keypoint a = pos(target); spread_angle 1cm")) == ["E0313"]
    assert codes(prim(motion="keypoint a = pos(target); duration 2")) == ["E0313"]
    assert codes(prim(motion="keypoint a = pos(target); duration -2s")) == ["E0406"]
    assert codes(prim(motion="keypoint a = pos(target); spread height(target)")) == ["E0314"]


def test_motion_defaults_and_settings() -> None:
    result = check(prim(motion="keypoint a = pos(target) gripper open; spread_angle 5deg"))
    assert result.program is not None
    p = result.program.primitive("p")
    assert (p.spread, p.duration) == (0.02, 2.0)
    assert p.spread_angle == pytest.approx(0.0872665)
    assert p.keypoints[0].gripper == "open"


def test_optimize_settings() -> None:
    ok = check(prim(extra="  optimize { samples 32; elites 4; iterations 3; seed 0 }"))
    assert ok.program is not None
    assert ok.program.primitive("p").optimize == ir.OptimizeSettings(32, 4, 3, 0)
    assert codes(prim(extra="  optimize { samples 8; elites 16 }")) == ["E0407"]
    assert codes(prim(extra="  optimize { elites 65 }")) == ["E0407"]   # 64 samples by default
    few = check(prim(extra="  optimize { samples 4 }")).program
    assert few is not None and few.primitive("p").optimize.elites == 4  # min(8, samples)
    assert codes(prim(extra="  optimize { sample 8 }")) == ["E0405"]
    assert codes(prim(extra="  optimize { samples 2.5 }")) == ["E0406"]
    assert codes(prim(extra="  optimize { iterations 0 }")) == ["E0406"]
    assert codes(prim(extra="  optimize { seed -1 }")) == ["E0406"]
    assert codes(prim(extra="  optimize { samples 4cm }")) == ["E0313"]
    defaults = check(prim()).program
    assert defaults is not None
    assert defaults.primitive("p").optimize == ir.OptimizeSettings(64, 8, 6, None)


def test_empty_success_block() -> None:
    assert codes(prim(success="")) == ["E0408"]


# ------------------------------------------------------------------------ params

def test_param_ranges_and_defaults_are_folded_constants() -> None:
    result = check(prim(extra="  params { a: Angle in [2 * 10deg, 90deg + 30deg] = 45deg }",
                        success="abs(rotation(target, about=up) - a) < 5deg"))
    assert result.diagnostics == []
    assert result.program is not None
    a = result.program.primitive("p").params[0]
    assert (a.low, a.high) == pytest.approx((0.3490658, 2.0943951))
    assert isinstance(a.default, ir.Const) and a.default.value == pytest.approx(0.7853982)


@pytest.mark.parametrize(("decl", "code"), [
    ("a: Angle in [20deg, 120deg] = 150deg", "E0315"),
    ("a: Angle in [120deg, 20deg]", "E0315"),
    ("a: Angle in [20, 120deg]", "E0313"),
    ("a: Angle = 90", "E0313"),
    ("a: Length = height(target)", "E0314"),
    ("a: Point in [1cm, 2cm]", "E0316"),
    ("a: Length in [1cm, b]", "E0201"),
])
def test_bad_param_ranges_and_defaults(decl: str, code: str) -> None:
    assert code in codes(prim(extra=f"  params {{ {decl} }}"))


# ---------------------------------------------------------------------- strategies

def test_role_map_names_every_role_once_with_a_compatible_kind() -> None:
    assert codes(strategy(TIP.replace(", hand=hand", ""))) == ["E0501"]
    assert codes(strategy(TIP.replace("hand=hand", "hand=hand, hand=hand"))) == ["E0502"]
    assert codes(strategy(TIP.replace("hand=hand", "hand=hand, paw=hand"))) == ["E0503"]
    assert codes(strategy(TIP.replace("support=table", "support=wall"))) == ["E0504"]
    assert codes(strategy(TIP.replace("support=table", "support=tabel"))) == ["E0201"]
    # subkind allowed: a Surface where flip wants a Fixture
    assert codes(strategy(TIP.replace("fixture=wall", "fixture=table")
                          .replace("reachable(hand, wall)", "reachable(hand, table)"))) == []


def test_phase_arguments() -> None:
    assert codes(strategy(TIP + " { angle = 45deg }")) == []
    assert codes(strategy(TIP + " { angle = 45deg; angle = 50deg }")) == ["E0506"]
    assert codes(strategy(TIP + " { angel = 45deg }")) == ["E0507"]
    assert codes(strategy(TIP + " { angle = 45 }")) == ["E0508"]
    assert codes(strategy(TIP + " { angle = 100deg + 50deg }")) == ["E0509"]
    assert codes(strategy(TIP + " { angle = 90deg - tilt(box) }")) == []   # checked at run time
    assert codes(strategy("  phase go: push(target=box, support=table, hand=hand)")) == ["E0505"]


def test_phase_arguments_see_lets_and_roles() -> None:
    body = ("  let margin = 1cm\n"
            "  phase go: push(target=box, support=table, hand=hand) {\n"
            "    displacement = (distance(box, wall) - margin) * direction(box, wall)\n  }")
    assert codes(strategy(body)) == []
    assert codes(strategy(body.replace("- margin", "- margn"))) == ["E0201"]


def test_lets_use_only_earlier_lets() -> None:
    assert codes(strategy(TIP + "\n  let a = 1cm\n  let b = a + 1cm\n"
                          "  success { height(box) > b }")) == []
    assert codes(strategy(TIP + "\n  let b = a + 1cm\n  let a = 1cm\n"
                          "  success { height(box) > b }")) == ["E0210"]


def test_phase_must_run_a_primitive() -> None:
    assert codes(strategy("  phase go: nudge(target=box)")) == ["E0201"]
    text = ("use stdlib.{flip}\nstrategy inner {\n  goal \"g\"\n  roles { box: Object }\n"
            "  phase x: flip(target=box)\n}\n")
    assert "E0213" in codes(text + strategy("  phase go: inner(box=box)"))
    assert codes(strategy("  phase go: distance(a=box)")) == ["E0201"]


def test_phase_names_are_unique() -> None:
    assert codes(strategy(TIP + "\n" + TIP)) == ["E0202"]


def test_strategy_required_blocks() -> None:
    assert codes('strategy s {\n  goal "g"\n  roles { box: Object }\n}\n') == ["E0401"]
    assert codes('use stdlib.grasp\nstrategy s {\n  roles { box: Object, h: Manipulator }\n'
                 '  phase t: grasp(target=box, hand=h)\n}\n') == ["E0401"]


def test_solve() -> None:
    def solve(text: str) -> list[str]:
        return codes(strategy("  phase go: push(target=box, support=table, hand=hand) {\n"
                              f"    displacement = {text}\n  }}"))
    assert solve("solve d: Point minimize norm(d) / 1cm subject { "
                 "(pos(box) + d).x > pos(wall).x + 5cm }") == []
    assert solve("solve d: Point minimize norm(d) subject { d.x > 1cm }") == ["E0308"]
    assert solve("solve d: Direction minimize norm(d) subject { d.x > 0 }") == ["E0508"]
    assert solve("solve d: Point minimize norm(d) / 1cm subject { d.x }") == ["E0318"]
    assert solve("solve d: Point minimize norm(d) / 1cm subject { d.x != 1cm }") == ["E0318"]
    assert solve("solve d: Point minimize 1 subject { 1cm > 0cm }") == ["E0318"]
    assert solve("solve box: Point minimize norm(box) / 1cm subject { }") == ["E0202"]
    assert solve("solve d: Object minimize 1 subject { }") == ["E0316"]


def test_solve_variable_reaches_only_symbolic_builtins() -> None:
    text = ("def far(p: Point) -> Length = norm(p)\n" + strategy(
        "  phase go: push(target=box, support=table, hand=hand) {\n"
        "    displacement = solve d: Point minimize far(d) / 1cm subject { d.z == 0cm }\n  }"))
    assert codes(text) == []


def test_unchecked_requires_substitute_the_role_map() -> None:
    text = (HEAD.replace("; reachable(hand, wall)", "") + TIP + "\n}\n")
    result = check(text)
    assert result.program is not None
    [phase] = result.program.strategy("s").phases
    assert [c.text for c in phase.unchecked_requires] == ["reachable(hand, wall)"]
    ref = phase.unchecked_requires[0].expr.args[1]  # type: ignore[union-attr]
    assert isinstance(ref, ir.Ref) and ref.name == "wall" and str(ref.type) == "Fixture"


def test_requires_stated_as_a_conjunction_count_as_stated() -> None:
    text = HEAD.replace("requires { on(box, table); faces(wall, box); reachable(hand, wall) }",
                        "requires { on(box, table) and faces(wall, box) and "
                        "reachable(hand, wall) }") + TIP + "\n}\n"
    result = check(text)
    assert result.program is not None
    assert result.program.strategy("s").phases[0].unchecked_requires == ()


# -------------------------------------------------------------------------- errors

def test_all_errors_are_reported_without_cascades() -> None:
    text = prim(success="distance(hand, nope) < 1cm; height(target) < 2; bogus(1)",
                cost="(height(target) / 1cm)^x")
    assert codes(text) == ["E0201", "E0302", "E0201", "E0304"]


def test_program_is_none_on_errors_and_diagnostics_are_sorted() -> None:
    result = check(prim(success="height(target) < 2; speed(target) < 1"))
    assert result.program is None
    lines = [(d.span.line, d.span.col) for d in result.diagnostics]
    assert lines == sorted(lines)


def test_yaml_programs_get_the_same_checks_on_yaml_lines() -> None:
    text = ("- primitive: p\n"
            "  goal: \"g\"\n"
            "  roles: {target: Object, hand: Manipulator}\n"
            "  success: [\"distance(hand, target) < 2\"]\n"
            "  cost: {final: \"distance(hand, target) / 1cm\"}\n"
            "  motion:\n"
            "    keypoints:\n"
            "      - {name: reach, at: \"pos(target)\"}\n")
    [d] = check(text, path="p.yaml").diagnostics
    assert d.code == "E0302" and d.span.path == "p.yaml" and d.span.line == 4


def test_phases_that_run_one_primitive_alike_share_their_w0105() -> None:
    """One warning per requirement for phases with the same primitive, roles and previous
    phase (n phases of a primitive with m requirements gave n x m warnings)."""
    text = prim(extra="  requires { touching(target, hand) }").replace(
        "success { touching(hand, target) }", "success { distance(hand, target) < 1cm }") + \
        strategy("\n".join(f"  phase {name}: p(target=box, hand=hand)" for name in "abcd"))
    result = check(text, lint=True)
    warnings = [d for d in result.diagnostics if d.code == "W0105"]
    assert [d.message for d in warnings] == [
        "`touching(box, hand)` is not in the strategy's `requires`; it is checked at run time "
        "when phase `a` starts",
        "`touching(box, hand)` is not in the strategy's `requires`; it is checked at run time "
        "when phases `b`, `c`, `d` start"]
    assert [d.span.line for d in warnings] == [text.splitlines().index(
        f"  phase {name}: p(target=box, hand=hand)") + 1 for name in "ab"]


def test_a_def_that_shadows_a_builtin_is_what_the_compiled_program_calls() -> None:
    from rapid_dsl.compiler import compile_program
    from rapid_dsl.runtime.loader import load

    text = ("def height(b: Body) -> Length = top(b) + 1cm\n"
            + prim(success="height(target) > 1cm").replace("primitive p", "primitive spin"))
    result = check(text)
    assert result.program is not None, [d.message for d in result.diagnostics]
    source = compile_program(result.program).source
    assert "def_height(" in source and "B.height(" not in source and "B.top(" in source
    assert load(source, "shadow").program.declaration("spin").name == "spin"
