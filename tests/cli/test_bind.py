"""`rapidc bind` and how `rapidc run` chooses a binding: real programs, real scenes, real MuJoCo."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from .box_scenes import boxes_scene

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "bind"
SCENES = ROOT / "examples" / "scenes"
PUSH, LEAN, NUDGE = DATA / "push.rapid", DATA / "lean.rapid", DATA / "nudge.rapid"
BUDGET = ("--samples", "4", "--iterations", "1")


def _json(run) -> dict:
    return json.loads(run.out)


def test_the_labelled_entity_is_ranked_first_among_distractors(rapidc):
    # Three crates on the table; only crate_b's label ("cereal box") matches the role `box`.
    run = rapidc("bind", PUSH, "--scene", DATA / "crates.yaml")
    assert run.code == 0, run.err
    lines = run.out.splitlines()
    assert lines[0] == f"shift on {DATA / 'crates.yaml'}: 3 bindings, showing 3"
    assert lines[1] == "  1. box=crate_b, table=table, hand=gripper  (score 2, 2 alternatives)"
    assert "best: the top-ranked binding scores 2, the next 1" in run.out
    report = _json(rapidc("bind", PUSH, "--scene", DATA / "crates.yaml", "--format", "json"))
    assert report["status"] == "best"
    assert [b["binding"]["box"] for b in report["bindings"]] == ["crate_b", "crate_a", "crate_c"]
    assert report["bindings"][0]["scores"] == {"box": 1.0, "table": 1.0, "hand": 0.0}


def test_a_hint_outranks_the_role_name(rapidc):
    run = rapidc("bind", PUSH, "--scene", DATA / "crates.yaml", "--hint", "box=cardboard crate",
                 "--format", "json")
    assert run.code == 0, run.err
    report = _json(run)
    assert report["bindings"][0]["binding"]["box"] == "crate_a"
    # crate_a matches the whole hint; crate_b half of it (`crate`) and the role name by its label.
    assert [(b["binding"]["box"], b["scores"]["box"]) for b in report["bindings"]] == [
        ("crate_a", 10.0), ("crate_b", 6.0), ("crate_c", 5.0)]


def test_an_ambiguous_binding_exits_1_and_counts_what_it_shows(rapidc):
    run = rapidc("bind", PUSH, "--scene", DATA / "twins.yaml", "--limit", "1")
    assert run.code == 1
    assert "twins.yaml: 2 bindings, showing 1\n" in run.out
    assert "box_left" in run.out and "box_right" not in run.out
    assert "ambiguous: 2 bindings tie at score 2; pin roles with --bind role=entity" in run.out
    report = _json(rapidc("bind", PUSH, "--scene", DATA / "twins.yaml", "--limit", "1",
                          "--format", "json"))
    assert (report["status"], report["total"], report["shown"]) == ("ambiguous", 2, 1)
    assert rapidc("bind", PUSH, "--scene", DATA / "twins.yaml", "--bind", "box=box_right").code \
        == 0


def test_the_floor_is_never_offered_for_a_fixture_role(rapidc):
    # flip_box has a wall; before the floor rule `wall=floor` was a second binding.
    report = _json(rapidc("bind", NUDGE, "--scene", SCENES / "flip_box.yaml", "--format", "json"))
    assert report["status"] == "unique"
    assert [b["binding"]["wall"] for b in report["bindings"]] == ["wall"]
    # push_box has no wall: no binding, and the floor is not one either.
    run = rapidc("bind", NUDGE, "--scene", SCENES / "push_box.yaml", "--hint", "wall=floor")
    assert run.code == 1
    assert "0 bindings" in run.out
    assert ("wall=floor: `floor` is a plane (the floor): a Surface only, with no side face for "
            "Fixture role `wall`") in run.out
    assert "table=table: `table` is the only entity role `wall` can take" in run.out
    pinned = rapidc("bind", NUDGE, "--scene", SCENES / "flip_box.yaml", "--bind", "wall=floor")
    assert pinned.code == 2
    assert "--bind wall=floor: `floor` is a plane (the floor): a Surface only" in pinned.err
    # The floor still fills Surface roles where a relation allows it.
    puck = _json(rapidc("bind", ROOT / "tests" / "data" / "run" / "shove.rapid", "--entry",
                        "shove", "--scene", ROOT / "tests" / "data" / "run" / "tabletop.yaml",
                        "--format", "json"))
    assert {"object": "puck", "support": "floor", "hand": "gripper"} in \
        [b["binding"] for b in puck["bindings"]]


def test_a_rejection_names_the_first_false_relation_with_its_value(rapidc):
    # The box rests against near_wall; far_wall stands 38 cm away across the table.
    run = rapidc("bind", LEAN, "--scene", DATA / "walls.yaml")
    assert run.code == 0, run.err
    assert "  1. box=box, table=table, wall=near_wall, hand=gripper" in run.out
    assert "  wall=far_wall: touching(box, wall) is false (distance 0.38 m)\n" in run.out
    assert ("  table=floor: on(box, table) is false (the bottom of box is 0.75 m from the top of "
            "floor, more than 0.01 m)\n") in run.out
    rejected = _json(rapidc("bind", LEAN, "--scene", DATA / "walls.yaml", "--format",
                            "json"))["rejected"]
    assert {"role": "wall", "entity": "far_wall",
            "reason": "touching(box, wall) is false (distance 0.38 m)",
            "requirement": "touching(box, wall)", "value": "distance 0.38 m"} in rejected


def test_json_shape(rapidc):
    run = rapidc("bind", LEAN, "--scene", DATA / "walls.yaml", "--format", "json")
    report = _json(run)
    assert list(report) == ["program", "entry", "scene", "status", "roles", "total", "complete",
                            "shown", "bindings", "rejected", "reason"]
    assert report["entry"] == "lean" and report["complete"] is True and report["reason"] is None
    assert report["roles"][2] == {"name": "wall", "kind": "Fixture"}
    (top,) = report["bindings"]
    assert list(top) == ["rank", "binding", "score", "scores", "alternatives"]
    assert top["rank"] == 1 and list(top["binding"]) == ["box", "table", "wall", "hand"]
    assert all(list(r) == ["role", "entity", "reason", "requirement", "value"]
               for r in report["rejected"])
    none = _json(rapidc("bind", NUDGE, "--scene", SCENES / "push_box.yaml", "--format", "json"))
    assert none["status"] == "none" and none["bindings"] == [] and none["total"] == 0
    assert none["reason"].startswith("no binding: ")


@pytest.mark.parametrize("extra, message", [
    (["--hint", "lid=red"], "--hint lid=...: no role `lid`; roles are box, table, hand"),
    (["--hint", "box"], "--hint box: expected NAME=VALUE"),
    (["--bind", "box=lid"], "--bind box=lid: the scene has no entity `lid`"),
    (["--bind", "table=crate_a"], "`crate_a` is of kind Object, role `table` needs Surface"),
    (["--limit", "0"], "--limit: must be at least 1"),
    (["--entry", "nothing"], "no primitive or strategy of that name"),
])
def test_bad_input_exits_2(rapidc, extra, message):
    run = rapidc("bind", PUSH, "--scene", DATA / "crates.yaml", *extra)
    assert run.code == 2
    assert message in run.err


def test_bad_files_exit_2(rapidc, write):
    scene = write("bad.yaml", "robot: floating_gripper\nobjects:\n  - name: box\n    kind: thing\n")
    run = rapidc("bind", PUSH, "--scene", scene)
    assert run.code == 2 and "bad.yaml:4" in run.err
    program = write("bad.rapid", "strategy s {\n  goal \"x\"\n  roles { a: Thing }\n}\n")
    run = rapidc("bind", program, "--scene", DATA / "crates.yaml")
    assert run.code == 2 and "unknown type `Thing`" in run.err
    assert rapidc("bind", DATA / "missing.rapid", "--scene", DATA / "crates.yaml").code == 2


def test_run_refuses_an_ambiguous_binding_with_the_candidates(rapidc):
    run = rapidc("run", PUSH, "--scene", DATA / "twins.yaml", *BUDGET)
    assert run.code == 2
    assert run.out == ""
    assert ("rapidc: error: the binding of `shift` is ambiguous: 2 bindings tie at score 2 "
            "(2 bindings in all, showing 2, best first):") in run.err
    assert "  1. box=box_left, table=table, hand=gripper" in run.err
    assert "  2. box=box_right, table=table, hand=gripper" in run.err
    assert "--bind role=entity" in run.err and "--best" in run.err


def test_run_best_takes_the_top_ranked_binding_and_says_so(rapidc, tmp_path):
    trace = tmp_path / "trace.json"
    run = rapidc("run", PUSH, "--scene", DATA / "twins.yaml", *BUDGET, "--best", "--quiet",
                 "--trace", trace)
    assert run.code in (0, 1), run.err
    result = json.loads(trace.read_text())
    assert result["binding"] == {"box": "box_left", "table": "table", "hand": "gripper"}
    assert result["binding_note"].startswith("--best: 2 bindings, the top ones tie at score 2; "
                                             "took the top-ranked (box=box_left, ")


def test_run_binds_the_labelled_entity_without_pins_or_hints(rapidc, tmp_path):
    trace = tmp_path / "trace.json"
    run = rapidc("run", PUSH, "--scene", DATA / "crates.yaml", *BUDGET, "--quiet", "--trace",
                 trace)
    assert run.code in (0, 1), run.err
    result = json.loads(trace.read_text())
    assert result["binding"]["box"] == "crate_b"
    assert "3 bindings; the top-ranked (box=crate_b, table=table, hand=gripper) scores 2" in \
        result["binding_note"]
    hinted = rapidc("run", PUSH, "--scene", DATA / "crates.yaml", *BUDGET, "--quiet", "--trace",
                    trace, "--hint", "box=cardboard")
    assert hinted.code in (0, 1), hinted.err
    assert json.loads(trace.read_text())["binding"]["box"] == "crate_a"


# ----------------------------------------------------------- a search bounded by its budget

def _five_roles(path: Path, requires: str) -> Path:
    path.write_text(f"""use stdlib.push

strategy many {{
  goal "bind five objects"
  roles {{ o1: Object, o2: Object, o3: Object, o4: Object, o5: Object,
           table: Surface, hand: Manipulator }}
  requires {{ {requires} }}
  phase shove: push(target=o1, support=table, hand=hand) {{ displacement = [4cm, 0cm, 0cm] }}
  success {{ on(o1, table) }}
}}
""", encoding="utf-8")
    return path


def _process(*argv: object) -> subprocess.CompletedProcess[str]:
    """`rapidc ARGV` in a new process, stopped (failing the test) after 60 s."""
    return subprocess.run([sys.executable, "-m", "rapid_dsl", *map(str, argv)], cwd=ROOT,
                          capture_output=True, text=True, timeout=60, check=False)


@pytest.mark.slow
def test_five_object_roles_on_sixty_two_boxes_bind_in_seconds(tmp_path):
    # `distance(o5, o1)` is checked as o1 and o5 are filled: 62 x 61 pairs, not 62^5
    # assignments (minutes before the search was ordered).
    program = _five_roles(tmp_path / "many.rapid", "distance(o5, o1) < 1mm")
    apart = _process("bind", program, "--scene", boxes_scene(tmp_path / "apart.yaml", 62))
    assert apart.returncode == 1, apart.stderr
    assert "no binding: distance(o5, o1) < 1mm is false for every candidate: (o1=b1, o5=b5)" \
        in apart.stdout
    touching = _process("bind", program, "--scene",
                        boxes_scene(tmp_path / "touching.yaml", 62, touching=True))
    assert touching.returncode == 0, touching.stderr
    assert "touching.yaml: more than 10000 bindings, showing 10" in touching.stdout
    assert "  1. o1=b1, o2=b2, o3=b3, o4=b4, o5=b0, table=table, hand=gripper" in touching.stdout


@pytest.mark.slow
def test_a_search_past_its_budget_exits_2_with_the_candidates_and_how_to_pin(tmp_path):
    # One clause over all five roles prunes nothing until they are all filled.
    program = _five_roles(tmp_path / "many.rapid",
                          "touching(o1, o2) and touching(o3, o4) and touching(o4, o5)")
    scene = boxes_scene(tmp_path / "boxes.yaml", 62)
    message = ("rapidc: error: binding the roles takes more than 10,000 relation evaluations, "
               "the limit: candidates per role: o1 62, o2 62, o3 62, o4 62, o5 62, table 2, "
               "hand 1 (about 10^9 assignments); pin roles with --bind role=entity to narrow "
               "the search\n")
    for command in (("bind",), ("run", "--samples", "4", "--iterations", "1")):
        refused = _process(command[0], program, "--scene", scene, *command[1:])
        assert (refused.returncode, refused.stderr) == (2, message), command
    pinned = _process("bind", program, "--scene", scene, "--bind", "o1=b0", "--bind", "o2=b1",
                      "--bind", "o3=b2")
    assert pinned.returncode == 1, pinned.stderr
    assert "is false for every candidate" in pinned.stdout
