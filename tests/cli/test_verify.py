"""`rapidc verify`: a program judged on a scene and its seeded variants, through the real CLI with
real MuJoCo and small CEM budgets; the report validated against `rapidc schema --report`."""

from __future__ import annotations

import json
import re
from pathlib import Path

import jsonschema
import pytest

from .test_run_input import SGR, _on_terminal

ROOT = Path(__file__).resolve().parents[2]
PUSH = ROOT / "examples" / "push_box.rapid"
SCENE = ROOT / "examples" / "scenes" / "push_box.yaml"
SMALL = ("--samples", "8", "--iterations", "1")
LOCATION = re.compile(r".+\.rapid:\d+:\d+")

# The push_box scene's box is 20 cm long: variants scale it by up to 15 %, so about half pass.
SHOVE = """\
use stdlib.push

strategy shove_box {
  goal "Push the box 5 cm away"
  roles { box: Object, table: Surface, hand: Manipulator }
  requires { on(box, table) }
  filter { extents(box).x < LIMIT }
  phase shove: push(target=box, support=table, hand=hand) { displacement = [5cm, 0cm, 0cm] }
  success { SUCCESS }
}
"""


def shove(write, limit: str = "20.5cm", success: str = "on(box, table)") -> Path:
    return write("shove.rapid", SHOVE.replace("LIMIT", limit).replace("SUCCESS", success))


def results(report: dict) -> list[dict]:
    """The per-run results, without how they ran (attempts, seconds)."""
    return [{k: v for k, v in r.items() if k != "execution"} for r in report["results"]]


@pytest.fixture
def schema(rapidc) -> dict:
    run = rapidc("schema", "--report")
    assert run.code == 0
    data = json.loads(run.out)
    jsonschema.Draft202012Validator.check_schema(data)
    return data


def validate(report: dict, schema: dict) -> None:
    jsonschema.validate(report, schema, cls=jsonschema.Draft202012Validator)


@pytest.mark.slow
def test_the_report_follows_its_schema_and_its_summary_counts_the_runs(rapidc, schema,
                                                                         tmp_path: Path):
    report_path = tmp_path / "report.json"
    run = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 3, *SMALL,
                 "--report", report_path)
    report = json.loads(report_path.read_text())
    validate(report, schema)
    assert report["complete"] and not (tmp_path / "report.json.journal").exists()
    assert [r["variant"] for r in report["results"]] == [None, 0, 1, 2]
    summary = report["summary"]
    outcomes = [r["outcome"] for r in report["results"]]
    assert summary["succeeded"] == outcomes.count("succeeded")
    assert summary["failed"] == outcomes.count("failed") and summary["runs"] == 4
    assert run.code == (0 if summary["succeeded"] == 4 else 1), run.err
    assert run.out.startswith(f"push_box (strategy) on {SCENE} and 3 variants of seed 0: "
                              f"{summary['succeeded']} of 4 runs succeeded")
    for record in report["results"]:
        assert record["binding"] == {"box": "box", "table": "table", "hand": "gripper"}
        phase = record["phases"][0]
        assert phase["arguments"]["displacement"] == [0.1, 0.0, 0.0]   # and push's defaults
        assert phase["planned_cost"] is not None and phase["executed_cost"] is not None
        for clause in phase["success"] + record["success"]:
            assert LOCATION.fullmatch(clause["location"]), clause
        if record["variant"] is not None:
            assert record["parameters"]["index"] == record["variant"]
            assert record["seed"] == 0 and record["parameters"]["objects"][0]["name"] == "box"
        if record["outcome"] == "failed":
            failure = record["first_failure"]
            assert failure["clause"] is not None and not failure["clause"]["holds"]
            assert failure["location"] == failure["clause"]["location"]
            assert failure["location"] in run.out    # the summary points at the clause


@pytest.mark.slow
def test_variants_a_filter_rejects_are_not_run_and_not_counted(rapidc, write, schema,
                                                              tmp_path: Path):
    program = shove(write)
    run = rapidc("verify", program, "--scene", SCENE, "--variants", 6, *SMALL,
                 "--report", tmp_path / "r.json")
    report = json.loads((tmp_path / "r.json").read_text())
    validate(report, schema)
    rejected = [r for r in report["results"] if r["outcome"] == "rejected"]
    assert 0 < len(rejected) < 6
    for record in rejected:
        assert record["phases"] == [] and record["first_failure"] is None
        clause = record["rejection"]["clause"]
        assert clause["text"] == "extents(box).x < 20.5cm" and not clause["holds"]
        assert clause["value"] > 0.205 and record["rejection"]["location"] == f"{program}:7:12"
    summary = report["summary"]
    assert summary["rejections"] == [{
        "where": "shove_box", "phase": None, "primitive": None,
        "clause": "extents(box).x < 20.5cm", "location": f"{program}:7:12",
        "count": len(rejected), "variants": [r["variant"] for r in rejected]}]
    ran = 7 - len(rejected)
    assert summary["success_rate"] == summary["succeeded"] / ran
    assert f"{summary['succeeded']} of {ran} runs succeeded" in run.out
    assert f"{len(rejected)}x  `shove_box`: `extents(box).x < 20.5cm` at {program}:7:12" \
        in run.out


@pytest.mark.slow
def test_a_phase_primitives_filter_names_the_phase_and_the_primitive(rapidc, write,
                                                                    tmp_path: Path):
    # push's filter wants the box under 15 cm tall: a 14.5 cm box grows past it in some variants
    tall = SCENE.read_text().replace("size: [20cm, 14cm, 3cm]", "size: [20cm, 14cm, 14.5cm]") \
        .replace("position: [0.55, 0.0, 1.5cm]", "position: [0.55, 0.0, 7.25cm]")
    scene = write("tall.yaml", tall)
    run = rapidc("verify", shove(write, limit="1m"), "--scene", scene, "--variants", 6, *SMALL,
                 "--report", tmp_path / "r.json")
    report = json.loads((tmp_path / "r.json").read_text())
    groups = [g for g in report["summary"]["rejections"] if g["where"] == "shove"]
    assert groups, report["summary"]
    lines = (ROOT / "stdlib_primitives" / "push.rapid").read_text().splitlines()
    line = next(i for i, text in enumerate(lines, 1) if text.startswith("  filter {"))
    where = f"<stdlib>/push.rapid:{line}:12"
    assert {k: groups[0][k] for k in ("phase", "primitive", "clause", "location")} == {
        "phase": "shove", "primitive": "push", "clause": "extents(target).z < 15cm",
        "location": where}
    assert f"phase `shove` (push): `extents(target).z < 15cm` at {where}" in run.out


def test_when_every_run_is_rejected_nothing_is_verified(rapidc, write):
    run = rapidc("verify", shove(write, limit="1cm"), "--scene", SCENE, "--variants", 2, *SMALL)
    assert run.code == 1
    assert "3 rejected" in run.out
    assert "every run was rejected by the program's filters: nothing was verified" in run.err


@pytest.mark.slow
def test_failures_are_grouped_and_min_success_relaxes_the_exit_status(rapidc, write,
                                                                     tmp_path: Path):
    program = shove(write, limit="1m", success="pos(box).z > 1m")   # cannot hold
    run = rapidc("verify", program, "--scene", SCENE, "--variants", 2, *SMALL,
                 "--report", tmp_path / "r.json")
    assert run.code == 1
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["summary"]["success_rate"] == 0.0
    groups = report["summary"]["failures"]
    assert sum(g["count"] for g in groups) == 3
    for group in groups:
        assert group["stage"] == "success" and LOCATION.fullmatch(group["location"])
        if group["phase"] is None:     # the strategy's own success block
            assert (group["clause"], group["location"]) == ("pos(box).z > 1m", f"{program}:9:13")
    relaxed = rapidc("verify", program, "--scene", SCENE, "--variants", 2, *SMALL,
                     "--min-success", 0, "--quiet")
    assert relaxed.code == 0 and relaxed.err == ""
    assert relaxed.out.count("\n") == 1


@pytest.mark.slow
def test_one_job_two_jobs_and_a_local_cluster_give_the_same_results(rapidc, tmp_path: Path):
    reports = {}
    for name, options in {"inline": (), "jobs": ("--jobs", 2),
                          "cluster": ("--cluster", "local:2")}.items():
        path = tmp_path / f"{name}.json"
        run = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 3, *SMALL, *options,
                     "--report", path, "--quiet")
        assert run.code in (0, 1), run.err
        reports[name] = json.loads(path.read_text())
    assert results(reports["jobs"]) == results(reports["inline"])
    assert results(reports["cluster"]) == results(reports["inline"])
    assert reports["jobs"]["summary"] == reports["inline"]["summary"]


@pytest.mark.slow
def test_resume_keeps_the_finished_runs_and_runs_the_rest(rapidc, tmp_path: Path):
    path = tmp_path / "r.json"
    first = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 2, *SMALL, "--report", path)
    assert first.code in (0, 1), first.err
    before = json.loads(path.read_text())["results"]
    more = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 4, *SMALL, "--resume", path)
    assert more.code in (0, 1), more.err
    after = json.loads(path.read_text())
    assert after["complete"] and [r["variant"] for r in after["results"]] == [None, 0, 1, 2, 3]
    assert after["results"][:3] == before   # kept as they were, timings too: not run again
    assert more.err.count("verify: ") == 2   # only the two new variants ran
    fresh = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 4, *SMALL,
                   "--report", tmp_path / "fresh.json")
    assert fresh.code == more.code
    assert results(json.loads((tmp_path / "fresh.json").read_text())) == results(after)


@pytest.mark.slow
def test_a_primitive_entry_runs_with_its_arguments_in_every_job(rapidc, schema,
                                                                tmp_path: Path):
    push = ROOT / "stdlib_primitives" / "push.rapid"
    missing = rapidc("verify", push, "--scene", SCENE, "--variants", 1)
    assert missing.code == 2 and "`push` needs --arg for: displacement" in missing.err
    path = tmp_path / "r.json"
    run = rapidc("verify", push, "--scene", SCENE, "--variants", 2, *SMALL, "--jobs", 2,
                 "--arg", "displacement=[8cm, 0cm, 0cm]", "--report", path, "-q")
    assert run.code in (0, 1), run.err
    report = json.loads(path.read_text())
    validate(report, schema)
    assert (report["kind"], report["settings"]["arguments"]) == \
        ("primitive", {"displacement": [0.08, 0.0, 0.0]})
    for record in report["results"]:
        assert record["phases"][0]["arguments"]["displacement"] == [0.08, 0.0, 0.0]
        assert record["success"] == record["phases"][0]["success"]


@pytest.mark.slow
def test_resume_refuses_a_report_whose_records_are_malformed(rapidc, tmp_path: Path):
    path = tmp_path / "r.json"
    assert rapidc("verify", PUSH, "--scene", SCENE, "--variants", 1, *SMALL,
                  "--report", path, "-q").code in (0, 1)
    report = json.loads(path.read_text())
    del report["results"][1]["rejection"]
    path.write_text(json.dumps(report))
    run = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 1, *SMALL, "--resume", path)
    assert run.code == 2, run.err
    assert f"--resume: {path}:1:" in run.err   # the column of the record
    assert "$.results[1].rejection: required field is missing" in run.err


@pytest.mark.slow
def test_resume_refuses_a_report_of_other_settings(rapidc, tmp_path: Path):
    path = tmp_path / "r.json"
    assert rapidc("verify", PUSH, "--scene", SCENE, "--variants", 1, *SMALL,
                  "--report", path, "-q").code in (0, 1)
    run = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 1, "--samples", 9,
                 "--iterations", 1, "--resume", path)
    assert run.code == 2
    assert f"--resume {path}: its settings differ from this run's" in run.err
    other_seed = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 1, *SMALL,
                        "--seed", 3, "--resume", path)
    assert other_seed.code == 2 and "its seed differ" in other_seed.err


@pytest.mark.parametrize("text, message", [
    ("not json", "not JSON"),
    ('{"format": "something else", "results": []}', "not a rapidc verify report"),
    ('{"format": "rapidc-verify/1", "fingerprint": {}, "results": [{"variant": 0}]}',
     "r.json:1:1: $.rapidc: required field is missing (and 32 more problems)"),
])
def test_resume_refuses_what_is_not_a_report(rapidc, tmp_path: Path, text: str, message: str):
    path = tmp_path / "r.json"
    path.write_text(text)
    run = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 1, "--resume", path)
    assert run.code == 2 and message in run.err and "Traceback" not in run.err


@pytest.mark.parametrize("options, message", [
    (("--variants", 0), "--variants: must be at least 1"),
    (("--variants", 10001), "--variants 10001: at most 10000"),
    (("--variants", 1, "--jobs", 0), "--jobs: must be at least 1"),
    (("--variants", 1, "--jobs", 2, "--cluster", "local:2"), "choose one"),
    (("--variants", 1, "--cluster", "local:0"), "local:N takes 1 to 256 workers"),
    (("--variants", 1, "--cluster", "nowhere"), "expected local:N or a scheduler address"),
    (("--variants", 1, "--min-success", 2), "--min-success: must be from 0 to 1"),
    (("--variants", 1, "--samples", 0), "--samples: must be at least 1"),
    (("--variants", 1, "--bind", "box"), "--bind box: expected NAME=VALUE"),
    (("--variants", 1, "--bind", "box=nothing"), "nothing"),
    (("--variants", 1, "--arg", "x=1"), "it takes no --arg"),
    (("--variants", 1, "--planning-dt", 0.003), "--planning-dt"),
])
def test_bad_options_are_usage_errors(rapidc, options: tuple, message: str):
    run = rapidc("verify", PUSH, "--scene", SCENE, *options)
    assert run.code == 2, run.err
    assert message in run.err and "Traceback" not in run.err


def test_bad_inputs_are_located_and_exit_2(rapidc, write, tmp_path: Path):
    scene = write("scene.yaml", SCENE.read_text().replace("mass: 0.3kg", "mass: -1kg"))
    run = rapidc("verify", PUSH, "--scene", scene, "--variants", 1)
    assert run.code == 2 and re.search(rf"{re.escape(str(scene))}:\d+:\d+: error: ", run.err)
    ranges = write("ranges.yaml", "yaw: 2cm\n")
    run = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 1, "--ranges", ranges)
    assert run.code == 2 and f"{ranges}:1:6: error: yaw:" in run.err
    broken = write("broken.rapid", PUSH.read_text().replace("[10cm, 0cm, 0cm]", "10deg"))
    run = rapidc("verify", broken, "--scene", SCENE, "--variants", 1)
    assert run.code == 2 and "error[E05" in run.err
    media = write("media", "a file")
    run = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 1, "--media", media)
    assert run.code == 2 and "a file, not a folder" in run.err


@pytest.mark.slow
def test_ranges_that_leave_no_room_for_a_variant_stop_the_run_with_what_finished(rapidc, write,
                                                                                tmp_path: Path):
    ranges = write("crowded.yaml", "distractors: 20\ndistractor:\n  size: [30cm, 40cm]\n")
    path = tmp_path / "r.json"
    run = rapidc("verify", PUSH, "--scene", SCENE, "--variants", 2, *SMALL, "--ranges", ranges,
                 "--report", path)
    assert run.code == 2
    assert (f"rapidc: error: {SCENE}: variant 0 of seed 0: every one of 50 draws was rejected, "
            "most often (50x) because there is no room for 20 distractors") in run.err
    report = json.loads(path.read_text())
    assert not report["complete"] and [r["variant"] for r in report["results"]] == [None]


@pytest.mark.slow
def test_the_report_is_never_written_over_an_input_or_through_a_link(rapidc, write,
                                                                     tmp_path: Path):
    program, scene = shove(write), write("scene.yaml", SCENE.read_text())
    for report in (scene, program):
        run = rapidc("verify", program, "--scene", scene, "--variants", 1, *SMALL,
                     "--report", report)
        assert run.code == 2 and "it is one of the inputs" in run.err, run.err
    assert scene.read_text() == SCENE.read_text()
    assert not (tmp_path / "scene.yaml.journal").exists()
    link = tmp_path / "link.json"
    link.symlink_to(tmp_path / "elsewhere.json")
    run = rapidc("verify", program, "--scene", scene, "--variants", 1, *SMALL, "--report", link)
    assert run.code == 2 and "is a symbolic link" in run.err
    assert not (tmp_path / "elsewhere.json").exists()


VERIFY = ("verify", str(PUSH), "--scene", str(SCENE), "--variants", "1", *SMALL)


@pytest.mark.slow
def test_a_terminal_gets_one_progress_bar_with_the_tally():
    code, output = _on_terminal(*VERIFY)
    assert code in (0, 1), output
    assert b"0/2" in output and b"2/2" in output and b"succeeded" in output
    assert b"verify: " not in output          # no plain progress lines on a terminal
    assert SGR.search(output)


@pytest.mark.slow
@pytest.mark.parametrize("how", [{"argv": ("--color", "never")}, {"env": {"NO_COLOR": "1"}}])
def test_no_colour_on_a_terminal_means_no_styling(how: dict):
    code, output = _on_terminal(*VERIFY, *how.get("argv", ()), **how.get("env", {}))
    assert code in (0, 1), output
    assert b"2/2" in output and not SGR.search(output), output
