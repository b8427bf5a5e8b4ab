"""What `rapidc run` says beyond the last state: vacuous success clauses, filters that reject the
scene before anything runs, a strategy that stops at its first failed phase, --planning-dt.

Through the real CLI on tests/data/run/verdicts.rapid (strategies around `shove`), tiny budgets.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rapid_dsl.cli import main
from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_file
from rapid_dsl.runtime.loader import load
from rapid_dsl.runtime.scenes.scene import load_scene
from rapid_dsl.runtime.scenes.world import build_world
from rapid_dsl.runtime.screening import screen

DATA = Path(__file__).resolve().parents[1] / "data" / "run"
PROGRAM = str(DATA / "verdicts.rapid")
SCENE = str(DATA / "tabletop.yaml")
BUDGET = ("--samples", "8", "--iterations", "1", "--seed", "0")


def run(capsys, entry: str, *extra: str, trace: Path | None = None) -> tuple[int, str, str, dict]:
    argv = ["run", PROGRAM, "--scene", SCENE, "--entry", entry, *BUDGET, *extra]
    if trace is not None:
        argv += ["--trace", str(trace)]
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err, json.loads(trace.read_text()) if trace is not None else {}


def test_a_success_clause_that_holds_before_anything_moves_is_a_warning(capsys, tmp_path):
    code, out, err, trace = run(capsys, "centre_heights", trace=tmp_path / "t.json")
    assert code == 0, out + err      # a warning, not a failure: the push did happen
    line = ("verdicts.rapid:49: warning: success clause `height(box) - height(table) > 5cm` "
            "already holds in the start state (39.5cm vs 5cm): it is no evidence of what the "
            "motion did")
    assert line in err.splitlines()
    assert "warning: verdicts.rapid:49: success clause `height(box)" in out      # the table too
    assert "pos(box).x - start_x" not in err              # the clause that needed the push
    assert [c["at_start"] for c in trace["success"]] == [True, False]
    assert trace["warnings"] == [{"origin": "verdicts.rapid:49", "phase": None,
                                  "message": line.split("warning: ", 1)[1]}]
    # the phase's own clauses: `on` holds at the start by nature and is not warned about
    assert [c["at_start"] for c in trace["phases"][0]["success"]] == [False, True]


def test_a_success_block_that_holds_entirely_at_the_start_names_every_clause(capsys, tmp_path):
    code, _, err, trace = run(capsys, "stops_at_failure", trace=tmp_path / "t.json")
    assert "verdicts.rapid:60: warning: the success block already holds in the start state: " \
           "`bottom(box) - top(table) < 1cm` (0cm vs 1cm) is met before anything moves" in err
    assert trace["success"][0]["holds"] and trace["success"][0]["at_start"]


def test_a_strategy_stops_at_its_first_failed_phase_and_exits_1(capsys, tmp_path):
    """Its success holds at the end (nothing moved the box), yet a phase failed: exit 1."""
    code, out, _, trace = run(capsys, "stops_at_failure", trace=tmp_path / "t.json")
    assert code == 1
    touch, push = trace["phases"]
    assert touch["status"] == "failed" and push["status"] == "not run" and push["rollouts"] == 0
    assert trace["outcome"] == "failed" and trace["succeeded"] is False
    assert trace["failure"] == ("phase `touch`: success clause `distance(hand, object) < -1cm` "
                                "(verdicts.rapid:8) is false: 4.51cm vs -1cm (the strategy "
                                "stopped there: push not run)")
    assert "FAILED" in out and "not run" in out


def test_a_strategy_filter_rejects_the_scene_before_anything_runs(capsys, tmp_path):
    code, out, _, trace = run(capsys, "tall_boxes_only", trace=tmp_path / "t.json")
    assert code == 1
    assert trace["outcome"] == "rejected" and trace["rejected"] is True and trace["phases"] == []
    assert trace["failure"] == ("rejected by the filter of `tall_boxes_only`: `extents(box).z > "
                                "10cm` (verdicts.rapid:69) is false: 4cm vs 10cm")
    clause = trace["filters"]["tall_boxes_only"][0]
    assert (clause["holds"], clause["value"], clause["bound"]) == (False, 0.04, 0.1)
    assert "REJECTED" in out and "filter of tall_boxes_only: extents(box).z > 10cm" in out


def test_a_phase_primitive_filter_rejects_the_scene_too(capsys):
    code, out, _, _ = run(capsys, "narrow_boxes_only", "--quiet")
    assert code == 1
    assert out == ("narrow_boxes_only: REJECTED: rejected by the filter of phase `push` "
                   "(narrow_shove): `extents(object).x < 5cm` (verdicts.rapid:39) is false: "
                   "12cm vs 5cm\n")


def test_filters_are_screened_per_scene_without_running_anything():
    """`screen` is what verification calls per variant: binding, lets and filters only."""
    checked = check_file(PROGRAM)
    assert checked.program is not None
    program = load(compile_program(checked.program).source, "verdicts").program
    flat = build_world(load_scene(SCENE))
    tall = build_world(flat.scene.with_object("box", size=(0.04, 0.04, 0.12),
                                              pose={"position": (0.5, 0.0, 0.06)}))
    rejected = screen(program, flat, "tall_boxes_only")
    assert rejected.rejected and rejected.failure is None
    assert rejected.binding == {"box": "box", "table": "table", "hand": "gripper"}
    accepted = screen(program, tall, "tall_boxes_only")
    assert not accepted.rejected and accepted.filters["tall_boxes_only"][0].holds
    assert accepted.filters["push"] == []          # shove has no filter of its own
    narrow = screen(program, tall, "narrow_boxes_only")
    assert not narrow.rejected and narrow.filters["push"][0].value == pytest.approx(0.04)


@pytest.mark.parametrize("value, message", [
    ("0.003", "--planning-dt: planning_dt 0.003 s must divide the control period 0.02 s"),
    ("1e-300", "--planning-dt: planning_dt 1e-300 s is below the minimum of 0.0005 s"),
    ("1e-6", "--planning-dt: planning_dt 1e-06 s is below the minimum of 0.0005 s"),
    ("0", "--planning-dt: must be a positive number of seconds"),
    ("-0.004", "--planning-dt: must be a positive number of seconds"),
    ("fast", "--planning-dt: `fast` is not a number of seconds"),
    ("nan", "--planning-dt: must be a positive number of seconds"),
])
def test_a_planning_timestep_that_does_not_divide_the_control_period_exits_2(
        capsys, value, message):
    code = main(["run", PROGRAM, "--scene", SCENE, "--entry", "centre_heights", *BUDGET,
                 "--planning-dt", value])
    assert code == 2
    assert message in capsys.readouterr().err


def test_planning_at_the_worlds_timestep_executes_exactly_the_plan(capsys, tmp_path):
    code, out, err, trace = run(capsys, "centre_heights", "--planning-dt", "0.002",
                                "--execute-elites", "1", trace=tmp_path / "t.json")
    assert code == 0, out + err
    phase = trace["phases"][0]
    assert phase["planning_dt"] == 0.002 and phase["executed_elites"] == 1
    assert phase["planned_cost"] == phase["executed_cost"] and phase["planned_success"] is True


def test_going_on_after_a_failed_phase_is_written_in_the_program(capsys, tmp_path):
    code, out, err, trace = run(capsys, "continues_after_failure", trace=tmp_path / "t.json")
    assert code == 0, out + err          # the strategy's success decides
    touch, push = trace["phases"]
    assert (touch["status"], touch["on_fail"]) == ("failed", "continue")
    assert (push["status"], push["on_fail"]) == ("succeeded", "stop")
    assert trace["succeeded"] and trace["failure"] is None


def test_a_phase_whose_success_holds_at_its_start_is_a_warning_per_clause(capsys, tmp_path):
    code, _, err, trace = run(capsys, "tiny_push", trace=tmp_path / "t.json")
    warned = [line for line in err.splitlines() if "warning:" in line]
    assert warned == [   # the strategy's block is judged first, then each phase at its start
        "verdicts.rapid:95: warning: the success block already holds in the start state: "
        "`pos(box).x - start_x > -1cm` (0cm vs -1cm) is met before anything moves",
        "shove.rapid:14: warning: phase `nudge`: the success block already holds in the phase's "
        "start state: `miss < 3cm` (1cm vs 3cm) is met before anything moves",
        "shove.rapid:15: warning: phase `nudge`: the success block already holds in the phase's "
        "start state: `on(object, support)` is met before anything moves"]
    assert [w["phase"] for w in trace["warnings"]] == [None, "nudge", "nudge"]


def test_a_primitive_entry_is_screened_by_its_own_filter(capsys):
    code, out, _, _ = run(capsys, "narrow_shove", "--arg", "displacement=[4cm, 0cm, 0cm]",
                          "--quiet")
    assert code == 1
    assert out == ("narrow_shove: REJECTED: rejected by the filter of `narrow_shove`: "
                   "`extents(object).x < 5cm` (verdicts.rapid:39) is false: 12cm vs 5cm\n")
