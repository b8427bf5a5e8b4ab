"""Every JSON file rapidc reads back is untrusted: a verify report (`rapidc report`), a verify
journal (`verify --resume`), the benchmark's journal (`bench nonprehensile --resume`), a track and
RGB-D intrinsics. Tampered or damaged ones are refused with exit 2 and the place of the problem,
never a traceback or exit 3; a refused resume leaves the journal byte for byte as it was; a
report reads no file outside its folder; a page stays small whatever the report holds.

The reports and journals are real: made by a real verify run and a real benchmark run, then
changed as a tampered file would be (hypothesis, tests/security/hostile_json.py)."""

from __future__ import annotations

import json
import random
import re
import shutil
from pathlib import Path
from typing import Any

import imageio.v2 as imageio
import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from rapid_dsl.runtime.demonstrations.track import TrackError, parse_track
from rapid_dsl.runtime.verification.report import ReportProblem, journal_path

from .conftest import run_rapidc
from .hostile_json import changed, changed_lines

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "examples" / "scenes" / "push_box.yaml"
SMALL = ("--samples", "4", "--iterations", "1")
BENCH = ("bench", "nonprehensile", "--tasks", "T1", "--scenes", "1", "--trials", "1", *SMALL,
         "-q")
CRASH = ("Traceback", "internal error")
FIXTURE = [HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
           HealthCheck.data_too_large]


@pytest.fixture(scope="module")
def verified(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A real verify run on the scene and 1 variant: its folder, program, report and the journal
    lines it would have left had it been stopped after its last run."""
    folder = tmp_path_factory.mktemp("verified")
    program = folder / "push_box.rapid"
    shutil.copy(ROOT / "examples" / "push_box.rapid", program)
    report = folder / "r.json"
    run = run_rapidc("verify", program, "--scene", SCENE, "--variants", 1, *SMALL, "--report",
                     report, "-q")
    assert run.code in (0, 1), run.err
    data = json.loads(report.read_text())
    header = {k: v for k, v in data.items()
              if k not in ("complete", "summary", "results", "seconds")}
    return {"folder": folder, "program": program, "report": report, "data": data,
            "lines": [header, *data["results"]]}


def resume(verified: dict[str, Any], folder: Path, journal: str,
           variants: int = 1) -> tuple[Any, bytes]:
    """`verify --resume` of a report whose journal holds `journal`: the run and the journal's
    bytes after it."""
    report = folder / "r.json"
    journal_path(report).write_text(journal, encoding="utf-8")
    run = run_rapidc("verify", verified["program"], "--scene", SCENE, "--variants", variants,
                     *SMALL, "--resume", report, "-q")
    after = journal_path(report).read_bytes() if journal_path(report).exists() else b""
    return run, after


def lines(records: list[Any]) -> str:
    return "".join(json.dumps(r, separators=(",", ":")) + "\n" for r in records)


# --- verify --resume -----------------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.parametrize(("value", "message"), [
    ("NaN", "r.json.journal:3:"), ("1e400", "r.json.journal:3:")])
def test_a_journal_record_with_a_number_json_cannot_hold_is_refused_and_kept(
        verified, tmp_path: Path, value: str, message: str):
    """On 8730720 the journal was rewritten from 3 lines to 2 and the run crashed (exit 3)."""
    text = _spoil_last(lines(verified["lines"]), f'"seconds":{value}')
    run, after = resume(verified, tmp_path, text)
    assert run.code == 2 and message in run.err and not any(c in run.err for c in CRASH)
    assert after == text.encode()


def _spoil_last(text: str, value: str) -> str:
    """The journal with the last record's run time replaced by `value`."""
    *head, last = text.splitlines()
    last = re.sub(r'"seconds":[^,}]+', value, last, count=1)
    return "\n".join([*head, last]) + "\n"


@pytest.mark.slow
@pytest.mark.parametrize(("header", "message"), [
    ({"fingerprint": "abc"}, "r.json.journal:1: $.fingerprint: Input should be a JSON object"),
    ({"fingerprint": [1, 2]}, "r.json.journal:1: $.fingerprint: Input should be a JSON object"),
])
def test_a_journal_whose_fingerprint_is_not_an_object_is_refused(verified, tmp_path: Path,
                                                                  header, message):
    text = lines([{**verified["lines"][0], **header}, *verified["lines"][1:]])
    run, after = resume(verified, tmp_path, text)
    assert run.code == 2 and message in run.err, run.err
    assert after == text.encode()


@pytest.mark.slow
def test_a_journal_line_of_50000_brackets_is_refused(verified, tmp_path: Path):
    text = lines(verified["lines"]) + "[" * 50_000 + "]" * 50_000 + "\n" + \
        lines(verified["lines"][1:2])
    run, after = resume(verified, tmp_path, text)
    assert run.code == 2 and "r.json.journal:4:1: nested too deeply" in run.err, run.err
    assert after == text.encode()


@pytest.mark.slow
def test_a_resumed_run_appends_to_its_journal_and_never_rewrites_it(verified, tmp_path: Path,
                                                                     monkeypatch):
    """The journal of a run stopped after the scene's run, with a torn line, a record of a
    variant past --variants and a lost job: the resumed run, itself stopped after one run,
    leaves every byte there and appends."""
    header, scene, variant = verified["lines"]
    later = {**variant, "variant": 7}
    lost = {**variant, "outcome": "error"}
    text = lines([header, scene, later, lost]) + '{"variant": 0, "outc'
    from rapid_dsl.runtime.verification.runner import Runner

    real, calls = Runner.run, []

    def stopped(self, index, payload):
        calls.append(index)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(self, index, payload)

    monkeypatch.setattr(Runner, "run", stopped)
    run, after = resume(verified, tmp_path, text, variants=2)
    assert run.code == 130, run.err
    assert after.startswith(text.encode() + b"\n")
    added = after[len(text) + 1:].decode().splitlines()
    assert json.loads(added[0])["fingerprint"] == header["fingerprint"]
    assert json.loads(added[1])["variant"] == 0 and len(added) == 2


@settings(max_examples=300, deadline=None, suppress_health_check=FIXTURE)
@given(data=st.data())
@pytest.mark.slow
def test_hostile_verify_journals_are_read_or_refused_and_left_alone(verified, tmp_path: Path,
                                                                     data):
    from rapid_dsl.runtime.verification.report import read_previous

    text = data.draw(changed_lines(verified["lines"]))
    path = journal_path(tmp_path / "r.json")
    path.write_text(text, encoding="utf-8")
    try:
        header, records, _ = read_previous(tmp_path / "r.json")
    except ReportProblem as problem:
        event("refused")
        assert str(problem).startswith(str(path))
    else:
        event("read")
        assert header["fingerprint"]["program"] and all("execution" in r for r in records)
    assert path.read_bytes() == text.encode()


@settings(max_examples=60, deadline=None, suppress_health_check=FIXTURE)
@given(data=st.data())
@pytest.mark.slow
def test_verify_resume_of_a_hostile_journal_is_exit_2_and_leaves_it(verified, tmp_path: Path,
                                                                    data):
    text = data.draw(changed_lines(verified["lines"]))
    run, after = resume(verified, tmp_path, text)
    event(f"exit {run.code}")
    assert not any(c in run.err for c in CRASH), run.err
    assert run.code in (0, 1, 2)
    if run.code == 2:
        assert after == text.encode()


# --- rapidc report -------------------------------------------------------------------------------

def page(report: dict[str, Any] | str, folder: Path, *options: object) -> tuple[Any, str]:
    source = folder / "r.json"
    source.write_text(report if isinstance(report, str) else json.dumps(report),
                      encoding="utf-8")
    html = folder / "p.html"
    html.unlink(missing_ok=True)
    run = run_rapidc("report", source, "--html", html, *options)
    return run, html.read_text(encoding="utf-8") if html.exists() else ""


@pytest.mark.slow
@pytest.mark.parametrize(("spoil", "message"), [
    (lambda t: t.replace('"success_rate": ', '"success_rate": ' + "9" * 401 + ", \"x\": ", 1),
     "a number has too many digits"),
    (lambda t: t.replace('"binding": {', '"binding": ' + "[" * 100_000 + "]" * 100_000
                         + ', "y": {', 1), "nested too deeply"),
])
def test_a_report_with_a_huge_integer_or_deep_nesting_is_exit_2(verified, tmp_path: Path,
                                                                spoil, message):
    run, html = page(spoil(json.dumps(verified["data"])), tmp_path)
    assert run.code == 2 and message in run.err and not html
    assert not any(c in run.err for c in CRASH)


@pytest.mark.slow
def test_a_report_reads_no_program_or_media_outside_its_folder(verified, tmp_path: Path):
    secret = tmp_path / "elsewhere"
    (secret / "media").mkdir(parents=True)
    (secret / "x.rapid").write_text("# SECRET-TEXT\n", encoding="utf-8")
    imageio.imwrite(secret / "media" / "scene.png", np.full((4, 4, 3), 7, np.uint8))
    report = {**verified["data"], "program": str(secret / "x.rapid"),
              "settings": {**verified["data"]["settings"], "media": str(secret / "media")}}
    own = tmp_path / "report"
    own.mkdir()
    run, html = page(report, own)
    assert run.code == 0, run.err
    assert "SECRET-TEXT" not in html and "data:image" not in html
    assert "lies outside the report&#39;s folder" in html
    assert "the program it names" in run.err and "the media folder it names" in run.err
    allowed, html = page(report, own, "--allow-path", secret)
    assert allowed.code == 0 and "SECRET-TEXT" in html and "data:image/png" in html


@pytest.mark.slow
def test_a_cost_curve_of_a_million_points_is_drawn_thinned(verified, tmp_path: Path):
    rng = random.Random(0)
    curve = [1.0]
    for _ in range(999_999):
        curve.append(curve[-1] + rng.uniform(-0.01, 0.01))
    curve[500_000] = 50.0                  # one spike: thinning must keep it
    report = json.loads(json.dumps(verified["data"]))
    report["results"][0]["phases"][0]["best_cost_per_iteration"] = curve
    run, html = page(report, tmp_path)
    assert run.code == 0, run.err
    assert len(html) < 500_000
    points = max(re.findall(r'<polyline points="([^"]*)"', html), key=len).split()
    assert len(points) <= 100
    assert f">{max(curve):.3g}<" in html and f">{min(curve):.3g}<" in html
    assert "drawn through the lowest and highest cost of each stretch" in html


@settings(max_examples=150, deadline=None, suppress_health_check=FIXTURE)
@given(data=st.data())
@pytest.mark.slow
def test_hostile_reports_are_exit_0_or_2_never_a_crash(verified, tmp_path: Path, data):
    text = data.draw(changed(verified["data"]))
    folder = tmp_path / "h"
    folder.mkdir(exist_ok=True)
    shutil.copy(verified["program"], folder / "push_box.rapid")
    run, html = page(text, folder)
    event(f"exit {run.code}")
    assert run.code in (0, 2) and not any(c in run.err for c in CRASH), run.err
    assert (run.code == 0) == bool(html)


# --- bench nonprehensile --resume ---------------------------------------------------------------

@pytest.fixture(scope="module")
def benched(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A real benchmark run of one scene of T1 (a trial and the control), and the journal lines
    it would have left had it been stopped after its last run."""
    out = tmp_path_factory.mktemp("bench") / "out"
    run = run_rapidc(*BENCH, "--out", out)
    assert run.code == 0, run.err
    data = json.loads((out / "results.json").read_text())
    header = {k: data[k] for k in ("format", "rapidc", "settings", "fingerprint")}
    records = [r for s in data["scenes"] for r in [*s["trials"], s["control"]]]
    return {"out": out, "lines": [header, *records]}


def bench_resume(out: Path, journal: str) -> tuple[Any, bytes]:
    (out / "results.json").unlink(missing_ok=True)
    path = out / "results.json.journal"
    path.write_text(journal, encoding="utf-8")
    run = run_rapidc(*BENCH, "--out", out, "--resume")
    return run, path.read_bytes() if path.exists() else b""


@pytest.mark.slow
@pytest.mark.parametrize(("change", "message"), [
    (lambda r: r | {"success": float("nan")}, "results.json.journal:2:"),
    (lambda r: r | {"key": [1]}, "results.json.journal:2: $.key: Input should be a valid string"),
    (lambda r: {k: v for k, v in r.items() if k != "execution"},
     "results.json.journal:2: $.execution: required field is missing"),
    (lambda r: r | {"success": "yes"},
     "results.json.journal:2: $.success: Input should be a valid boolean"),
])
def test_a_bad_bench_record_is_refused_before_any_run_and_kept(benched, tmp_path: Path,
                                                               change, message):
    """On 8730720 these crashed (exit 3), a NaN after cutting the journal to its header, the
    others after every run, with the bad record left for the next resume to crash on again."""
    header, trial, control = benched["lines"]
    out = tmp_path / "out"
    shutil.copytree(benched["out"], out)
    text = "".join(json.dumps(r, separators=(",", ":")) + "\n"
                   for r in (header, change(trial), control))
    run, after = bench_resume(out, text)
    assert run.code == 2 and message in run.err, run.err
    assert not any(c in run.err for c in CRASH)
    assert after == text.encode()


@settings(max_examples=300, deadline=None, suppress_health_check=FIXTURE)
@given(data=st.data())
@pytest.mark.slow
def test_hostile_bench_journals_are_read_or_refused_and_left_alone(benched, tmp_path: Path,
                                                                   data):
    from rapid_dsl.bench.nonprehensile.run import RESULTS, BenchError, _previous

    text = data.draw(changed_lines(benched["lines"]))
    path = tmp_path / f"{RESULTS}.journal"
    path.write_text(text, encoding="utf-8")
    try:
        records, journal = _previous(tmp_path / RESULTS, benched["lines"][0])
    except BenchError as problem:
        event("refused")
        assert "--resume" in str(problem)
    else:
        event("read")
        assert journal == path and all(isinstance(r["success"], bool) for r in records.values())
    assert path.read_bytes() == text.encode()


@settings(max_examples=20, deadline=None, suppress_health_check=FIXTURE)
@given(data=st.data())
@pytest.mark.slow
def test_bench_resume_of_a_hostile_journal_is_exit_2_and_leaves_it(benched, tmp_path: Path,
                                                                   data):
    text = data.draw(changed_lines(benched["lines"], first=1))   # the records: the header's
    out = tmp_path / "out"                                      # fingerprint is checked first
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(benched["out"], out)
    run, after = bench_resume(out, text)
    event(f"exit {run.code}")
    assert run.code in (0, 2) and not any(c in run.err for c in CRASH), run.err
    if run.code == 2:
        assert after == text.encode()


# --- tracks ---------------------------------------------------------------------------------------

TRACK = {"format": "rapidc-track/1", "hand": "gripper",
         "entities": [{"name": "box", "kind": "Object", "shape": "box",
                       "extents": [0.1, 0.1, 0.1]},
                      {"name": "gripper", "kind": "Manipulator", "shape": "gripper",
                       "extents": [0.02, 0.08, 0.05]}],
         "frames": [{"t": t, "objects": {"box": {"position": [0.5, 0.0, 0.05],
                                                 "quat": [1.0, 0.0, 0.0, 0.0]}},
                     "hand": {"position": [0.4, 0.0, 0.2], "quat": [1.0, 0.0, 0.0, 0.0],
                              "opening": 0.08}} for t in (0.0, 0.1, 0.2)]}


def test_the_track_the_hostile_ones_start_from_is_valid():
    assert parse_track(json.dumps(TRACK)).hand == "gripper"


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(changed(TRACK))
def test_hostile_tracks_are_read_or_refused_with_a_place(text: str):
    from rapid_dsl.language.safe_json import JsonError

    try:
        parse_track(text, "t.json")
        event("read")
    except TrackError as error:
        event("refused")
        assert isinstance(error, JsonError)
        assert all(p.file == "t.json" for p in error.problems) and str(error)


# --- rapidc mcp: a run's trace read back as the call's result -----------------------------------

@pytest.mark.parametrize("text", ["[" * 100_000, "[NaN]", "9" * 401, '{"t": 1e400}'])
def test_a_result_file_that_is_not_strict_json_is_no_result(tmp_path: Path, text: str):
    """A `run` call that fails before writing its trace leaves whatever file the caller put at
    the trace path; on 8730720 100,000 brackets there stopped the call with a RecursionError."""
    from rapid_dsl.mcp.arguments import Call
    from rapid_dsl.mcp.tools import TOOLS

    path = tmp_path / "trace.json"
    path.write_text(text, encoding="utf-8")
    call = Call(next(t for t in TOOLS if t.name == "run"), [], result_file=str(path))
    assert call.result() is None
    path.write_text('{"outcome": "succeeded"}', encoding="utf-8")
    assert call.result() == {"outcome": "succeeded"}
