"""Every stdlib primitive reaches its success predicate in its demonstration scene, and on seeded
variants of it (pose, size, mass, friction), with real MuJoCo and a small CEM budget.

Each demo program in examples/ runs one or more stdlib primitives; the run's trace says which
phases ran and whether each success clause held. Full budgets are for `rapidc bench primitives`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from rapid_dsl.cli import main
from rapid_dsl.runtime.scenes.scene import dump_scene, load_scene
from rapid_dsl.runtime.variants.sampler import VariantRanges, sample_variants

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
BUDGET = {"samples": 12, "iterations": 2}
BUDGETS = {"flip_box": {"samples": 24, "iterations": 3}}  # flip needs a few more rollouts

# demo program, scene, and the stdlib primitives its phases run
DEMOS = {
    "push_box": ("push_box.yaml", {"push"}),
    "press_book": ("press_book.yaml", {"press_move"}),
    "flip_box": ("flip_box.yaml", {"push", "flip"}),
    "pivot_bar": ("pivot_bar.yaml", {"pivot"}),
    "topple_carton": ("topple_box.yaml", {"topple"}),
    "pick_and_place": ("grasp_block.yaml", {"grasp", "lift", "move"}),
    "keep_clear": ("flip_box.yaml", {"push"}),   # its argument comes from a `solve`
    "hop_over": ("push_box.yaml", {"reach", "retreat"}),
    "place_block": ("grasp_block.yaml", {"grasp", "lift", "move", "release"}),
}
# Variants kept mild so they preserve each demo's task (the programs' filters would decide this
# in verification); what changes is real: position, yaw, size, mass and friction of every object.
MILD = VariantRanges(position=0.015, yaw=math.radians(8), size=0.08, mass=0.25, friction=0.15)


def _run(program: Path, scene: Path, trace: Path) -> dict:
    budget = BUDGETS.get(program.stem, BUDGET)
    code = main(["run", str(program), "--scene", str(scene), "--seed", "0", "--quiet",
                 "--trace", str(trace), "--samples", str(budget["samples"]),
                 "--iterations", str(budget["iterations"])])
    result = json.loads(trace.read_text())
    assert code == (0 if result["succeeded"] else 1)
    return result


def _failure(result: dict) -> str:
    lines = [result.get("failure") or ""]
    for phase in result["phases"]:
        lines += [f"{phase['name']}: {c['text']} = {c['value']} holds={c['holds']}"
                  for c in phase["success"]]
    return "\n".join(lines)


def test_stdlib_and_examples_lint_clean_under_strict(capsys):
    """What the project ships passes `rapidc lint --strict`: no warning for a user to inherit."""
    assert main(["lint", "--strict", str(ROOT / "stdlib_primitives"), str(EXAMPLES)]) == 0, \
        capsys.readouterr().out


def test_every_stdlib_primitive_has_a_demo():
    stdlib = {p.stem for p in (ROOT / "stdlib_primitives").glob("*.rapid")}
    covered = set().union(*(primitives for _, primitives in DEMOS.values()))
    assert stdlib == covered
    assert {p.stem for p in EXAMPLES.glob("*.rapid")} == set(DEMOS)


@pytest.mark.slow
@pytest.mark.parametrize("demo", sorted(DEMOS))
def test_demo_succeeds_in_its_scene(demo: str, tmp_path: Path):
    scene, primitives = DEMOS[demo]
    result = _run(EXAMPLES / f"{demo}.rapid", EXAMPLES / "scenes" / scene, tmp_path / "t.json")
    assert result["succeeded"], _failure(result)
    assert {p["primitive"] for p in result["phases"]} == primitives
    assert all(p["status"] == "succeeded" for p in result["phases"]), _failure(result)
    # no success clause of a demo is met before its motion (pick_and_place once compared centres)
    assert result["warnings"] == []


@pytest.mark.slow
@pytest.mark.parametrize("index", [0, 1])
@pytest.mark.parametrize("demo", sorted(DEMOS))
def test_demo_succeeds_on_seeded_variants(demo: str, index: int, tmp_path: Path):
    scene_file, _ = DEMOS[demo]
    base = load_scene(EXAMPLES / "scenes" / scene_file)
    variant = sample_variants(base, 2, seed=11, ranges=MILD)[index]
    assert variant.scene != base
    path = tmp_path / scene_file
    dump_scene(variant.scene, path)
    result = _run(EXAMPLES / f"{demo}.rapid", path, tmp_path / "t.json")
    assert result["succeeded"], f"variant {variant.describe()}\n{_failure(result)}"


@pytest.mark.slow
def test_a_solved_argument_drives_the_phase(tmp_path: Path):
    """keep_clear's displacement is the smallest push leaving 15 cm to the wall (CasADi)."""
    scene = load_scene(EXAMPLES / "scenes" / "flip_box.yaml")
    box, wall = scene.object("box"), scene.object("wall")
    result = _run(EXAMPLES / "keep_clear.rapid", EXAMPLES / "scenes" / "flip_box.yaml",
                  tmp_path / "t.json")
    dx, dy, dz = result["phases"][0]["arguments"]["displacement"]
    # both stand square to x in the demo scene, so their half extents along x are half their size
    wanted = (wall.pose.position[0] - wall.extents[0] / 2 - 0.15 - box.extents[0] / 2) \
        - box.pose.position[0]
    assert dx == pytest.approx(min(wanted, 0.0), abs=1e-4)
    assert dy == pytest.approx(0.0, abs=1e-6) and dz == pytest.approx(0.0, abs=1e-6)


@pytest.mark.slow
def test_a_push_asked_for_10cm_moves_the_box_10cm(tmp_path: Path):
    scene = EXAMPLES / "scenes" / "push_box.yaml"
    start = load_scene(scene).object("box").pose.position
    result = _run(EXAMPLES / "push_box.rapid", scene, tmp_path / "t.json")
    end = result["final_poses"]["box"]["position"]
    moved = math.hypot(end[0] - start[0], end[1] - start[1])
    assert moved == pytest.approx(0.10, abs=0.02)
    assert abs(end[1] - start[1]) < 0.02  # along +x, as asked


@pytest.mark.slow
def test_the_same_program_runs_on_the_franka_arm(tmp_path: Path):
    """Programs see one Manipulator: the push demo runs unchanged with the 7-DoF arm."""
    scene = EXAMPLES / "scenes" / "push_box_franka.yaml"
    assert load_scene(scene).robot == "franka"
    result = _run(EXAMPLES / "push_box.rapid", scene, tmp_path / "t.json")
    assert result["succeeded"], _failure(result)


def test_the_stdlib_page_describes_every_primitive():
    page = (ROOT / "docs" / "stdlib.md").read_text()
    for primitive in (ROOT / "stdlib_primitives").glob("*.rapid"):
        assert f"| `{primitive.stem}` |" in page


def test_stdlib_and_examples_are_in_canonical_format():
    files = [str(p) for p in sorted((ROOT / "stdlib_primitives").glob("*.rapid"))]
    files += [str(p) for p in sorted(EXAMPLES.glob("*.rapid"))]
    assert main(["fmt", "--check", "--quiet", *files]) == 0


@pytest.mark.slow
@pytest.mark.parametrize("angle", ["90deg", "-90deg"])
def test_pivot_turns_a_quarter_turn_either_way(angle: str, tmp_path: Path):
    trace = tmp_path / "t.json"
    code = main(["run", str(ROOT / "stdlib_primitives" / "pivot.rapid"), "--scene",
                 str(EXAMPLES / "scenes" / "pivot_bar.yaml"), "--arg", f"angle={angle}",
                 "--seed", "0", "--quiet", "--trace", str(trace), "--samples", "12",
                 "--iterations", "2"])
    result = json.loads(trace.read_text())
    assert code == 0, _failure(result)
