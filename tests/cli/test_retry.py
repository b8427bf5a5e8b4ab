"""`phase ... retry N`: parsed, checked, formatted, in the YAML form, compiled, and run end to end.

tests/data/run/retry.rapid pushes a box with a 4 cm stroke toward a line 8 cm away, so the first
attempt fails by construction and the second succeeds; `shrinking` computes its stroke from the
state, and the retry's value falls outside the param's range. Real MuJoCo, tiny budgets.
"""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest

from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_file

DATA = Path(__file__).resolve().parents[1] / "data" / "run"
PROGRAM = DATA / "retry.rapid"
SCENE = DATA / "tabletop.yaml"
BUDGET = ("--samples", "8", "--iterations", "1", "--seed", "0")

HEAD = """use stdlib.push

strategy s {
  goal "Push"
  roles { box: Object, table: Surface, hand: Manipulator }
"""
PUSH = "  phase a: push(target=box, support=table, hand=hand) { displacement = [1cm, 0cm, 0cm] }"


def test_retry_is_checked_and_compiled_only_where_it_is_given(write):
    path = write("s.rapid", HEAD + PUSH + " retry 2 on_fail continue\n"
                 + PUSH.replace("phase a", "phase b") + " on_fail continue retry 0\n"
                 + PUSH.replace("phase a", "phase c") + "\n}\n")
    result = check_file(str(path))
    assert result.diagnostics == [] and result.program is not None
    phases = result.program.strategy("s").phases
    assert [(p.retry, p.on_fail) for p in phases] == [(2, "continue"), (0, "continue"),
                                                      (0, "stop")]
    source = compile_program(result.program).source
    assert source.count("retry=2") == 1 and "retry=0" not in source


def test_a_retry_count_must_be_a_small_non_negative_integer(rapidc, write):
    for count, expected in (("6", "s.rapid:6:96: error[E0413]: `retry` 6 is above the maximum "
                                  "of 5"),
                            ("1.5", "s.rapid:6:96: error[E0406]: `retry` must be a non-negative "
                                    "integer"),
                            ("-1", "s.rapid:6:96: error[E0406]: `retry` must be a non-negative "
                                   "integer"),
                            ("2cm", "s.rapid:6:96: error[E0313]: `retry` must be a Real"),
                            ("pos(box).x", "s.rapid:6:100: error[E0314]: `retry` must be a "
                                           "constant")):
        path = write("s.rapid", HEAD + PUSH + f" retry {count}\n}}\n")
        run = rapidc("check", path)
        assert run.code == 1, count
        assert expected in run.out + run.err, (count, run.out + run.err)


def test_retry_is_still_a_name_outside_a_phase(write):
    path = write("s.rapid", HEAD + "  let retry = 2cm\n" + PUSH.replace("1cm, 0cm", "retry, 0cm")
                 + " retry 1\n}\n")
    result = check_file(str(path))
    assert result.diagnostics == [] and result.program is not None


def test_fmt_writes_retry_before_on_fail_on_one_line_and_after_a_block(rapidc, write):
    path = write("s.rapid", HEAD + PUSH + " on_fail continue retry 2\n}\n")
    run = rapidc("fmt", path)
    assert run.code == 0, run.err
    assert "  } retry 2 on_fail continue\n" in run.out
    assert rapidc("fmt", "--check", write("t.rapid", run.out)).code == 0
    short = write("u.rapid", HEAD + "  phase a: push(target=box, support=table, hand=hand) "
                  "retry 1\n}\n")
    assert "  phase a: push(target=box, support=table, hand=hand) retry 1\n" \
        in rapidc("fmt", short).out


def test_retry_in_the_yaml_form(rapidc, write):
    text = """- use: stdlib.push
- strategy: s
  goal: Push
  roles: {box: Object, table: Surface, hand: Manipulator}
  phases:
    - name: a
      primitive: push
      roles: {target: box, support: table, hand: hand}
      args: {displacement: "[1cm, 0cm, 0cm]"}
      retry: RETRY
"""
    result = check_file(str(write("s.rapid.yaml", text.replace("RETRY", "2"))))
    assert result.diagnostics == [] and result.program is not None
    assert result.program.strategy("s").phases[0].retry == 2
    assert "} retry 2\n" in rapidc("fmt", write("t.rapid.yaml", text.replace("RETRY", "2"))).out
    bad = rapidc("check", write("u.rapid.yaml", text.replace("RETRY", "9")))
    assert bad.code == 1 and "u.rapid.yaml:10:14: error[E0413]" in bad.out + bad.err


def test_a_phase_that_fails_once_is_tried_again_from_the_state_it_reached(rapidc, tmp_path):
    trace_path = tmp_path / "trace.json"
    run = rapidc("run", PROGRAM, "--scene", SCENE, "--entry", "twice", *BUDGET,
                 "--trace", trace_path)
    assert run.code == 0, run.out + run.err
    assert "phase push (2nd attempt) (step): optimizing" in run.err
    rows = [line.split() for line in run.out.splitlines() if line.strip().startswith("push ")]
    assert [row[:4] for row in rows] == [["push", "step", "failed", "past=58cm,"],
                                         ["push", "(2nd", "attempt)", "step"]]
    trace = json.loads(trace_path.read_text())
    phase = trace["phases"][0]
    assert phase["retry"] == 2 and phase["status"] == "succeeded"
    first, second = phase["attempts"]
    assert (first["number"], first["status"], first["moved"], first["seed"]) == \
        (1, "failed", True, [0])
    assert first["failure"].startswith("success clause `short < 0cm` (retry.rapid:13) is false")
    assert (second["number"], second["status"], second["seed"]) == (2, "succeeded", [0, 2])
    # the stroke is 4 cm and the line 8 cm away: one stroke cannot reach it, two do
    assert 1 < first["executed_cost"] < 4 and second["executed_cost"] < 0


def test_a_retried_argument_outside_its_range_is_a_reported_failure(rapidc, tmp_path):
    trace_path = tmp_path / "trace.json"
    run = rapidc("run", PROGRAM, "--scene", SCENE, "--entry", "shrinking", *BUDGET,
                 "--trace", trace_path)
    assert run.code == 1 and "Traceback" not in run.err
    trace = json.loads(trace_path.read_text())
    attempts = trace["phases"][0]["attempts"]
    # the second attempt computes what is left of 4.5 cm, below 1 cm; it does not move, and
    # a third would see the same state: the retries end there
    assert [(a["status"], a["moved"]) for a in attempts] == [("failed", True), ("failed", False)]
    assert "is outside its range [1cm, 5cm]" in attempts[1]["failure"]
    assert trace["failure"].startswith("phase `push` (2 attempts): argument stroke = ")
    assert "failure: phase `push` (2 attempts): argument stroke = " in run.out


@pytest.mark.slow
def test_the_verify_report_says_how_many_attempts_a_phase_took(rapidc, tmp_path):
    report_path = tmp_path / "report.json"
    run = rapidc("verify", PROGRAM, "--scene", SCENE, "--entry", "twice", "--variants", 1,
                 "--samples", 8, "--iterations", 1, "--report", report_path)
    assert run.code in (0, 1), run.out + run.err
    schema = json.loads(rapidc("schema", "--report").out)
    report = json.loads(report_path.read_text())
    jsonschema.validate(report, schema, cls=jsonschema.Draft202012Validator)
    scene = next(r for r in report["results"] if r["variant"] is None)
    phase = scene["phases"][0]
    assert phase["retry"] == 2
    assert [a["status"] for a in phase["attempts"]] == ["failed", "succeeded"]
