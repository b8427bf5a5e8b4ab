"""Every example program of the language reference checks clean, against the stub stdlib."""

from __future__ import annotations

from pathlib import Path

import pytest

from rapid_dsl.frontend.driver import check_file
from rapid_dsl.language.diagnostics import render_human

DATA = Path(__file__).parent.parent / "data"
STUBS = DATA / "stub_stdlib"
EXAMPLES = sorted((DATA / "language").glob("*.rapid"))


def _report(result) -> str:  # type: ignore[no-untyped-def]
    return "\n".join(render_human(d, result.sources.get(d.span.path)) for d in result.diagnostics)


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_language_example_checks_clean(path: Path) -> None:
    result = check_file(str(path), stdlib=STUBS, lint=False)
    assert result.diagnostics == [], _report(result)
    assert result.program is not None


def test_flip_example_types_every_block() -> None:
    result = check_file(str(DATA / "language" / "flip.rapid"), stdlib=STUBS)
    assert result.program is not None
    flip = result.program.primitive("flip")
    assert [r.kind for r in flip.roles] == ["Object", "Surface", "Fixture", "Manipulator"]
    angle = flip.params[0]
    assert (angle.low, angle.high) == pytest.approx((0.3490658, 2.0943951))
    assert [f.name for f in flip.features] == ["axis", "turned", "gap"]
    assert [k.name for k in flip.keypoints] == ["approach", "press", "lift"]
    assert flip.keypoints[1].gripper == "closed"
    assert flip.duration == 3.0 and flip.spread == pytest.approx(0.02)
    assert (flip.optimize.samples, flip.optimize.elites, flip.optimize.iterations) == (64, 8, 6)
    assert flip.progress_weight == pytest.approx(0.1)
    assert flip.success[2].text == "gap < 2cm"
    assert result.program.own == ("flip",)


def test_strategy_example_phases_and_unchecked_requires() -> None:
    result = check_file(str(DATA / "language" / "flip_and_grasp.rapid"), stdlib=STUBS)
    assert result.program is not None
    strategy = result.program.strategy("flip_and_grasp")
    assert [p.name for p in strategy.phases] == ["approach", "tip", "take"]
    tip = strategy.phases[1]
    assert tip.role_map == (("target", "box"), ("support", "table"), ("fixture", "wall"),
                            ("hand", "hand"))
    # on(box, table) and faces(wall, box) are stated by the strategy; reachable is not.
    assert [c.text for c in tip.unchecked_requires] == ["reachable(hand, wall)"]
    assert [c.text for c in strategy.phases[0].unchecked_requires] == ["reachable(hand, box)"]


def test_real_stdlib_and_examples_check_clean() -> None:
    root = Path(__file__).parent.parent.parent
    files = sorted((root / "stdlib_primitives").glob("*.rapid")) + \
        sorted((root / "examples").glob("*.rapid"))
    assert files
    for path in files:
        result = check_file(str(path))
        assert result.diagnostics == [], _report(result)
