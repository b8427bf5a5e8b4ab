"""`rapidc bench nonprehensile` end to end: one scene per registered task, the results file and
its scene files, --jobs 1 and 2 agreeing, resuming an interrupted run, and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rapid_dsl.bench.nonprehensile import tasks as registry
from rapid_dsl.runtime.scenes.scene import load_scene

OWN = Path(__file__).parents[1] / "runtime" / "bench_task" / "push_region.py"
BUDGET = ("--samples", 4, "--iterations", 1)
KEYS = ["P1", *(t.key for t in registry.available())]


@pytest.fixture(autouse=True)
def own_task(monkeypatch):
    """The small push task of tests/runtime/bench_task beside the registered ones."""
    monkeypatch.setitem(registry.MODULES, "P1", str(OWN))


def _results(out: Path) -> dict:
    return json.loads((out / "results.json").read_text())


def _same(record: dict) -> dict:
    """A record without its timing (which depends on the machine) and its output folder."""
    return {k: v for k, v in record.items() if k not in ("execution", "scene_file")}


@pytest.mark.slow
@pytest.mark.parametrize("key", KEYS)
def test_one_scene_one_trial_of_each_task(rapidc, tmp_path: Path, key: str):
    out = tmp_path / "bench"
    run = rapidc("bench", "nonprehensile", "--tasks", key, "--scenes", 1, "--trials", 1,
                 "--out", out, "--json", tmp_path / "copy.json", *BUDGET)
    assert run.code == 0, run.err
    assert f"{key} " in run.out and "Average" in run.out and "control" in run.out
    results = _results(out)
    assert results == json.loads((tmp_path / "copy.json").read_text())
    assert results["complete"] and results["settings"]["robot"] == "franka"
    assert results["machine"]["cpus"] >= 1 and "commit" in results
    (scene,) = results["scenes"]
    assert scene["task"] == key and scene["index"] == 0 and scene["binding"]
    assert load_scene(scene["scene_file"]).robot == "franka"   # replayable with rapidc run
    (trial,) = scene["trials"]
    assert trial["key"] == f"{key}/000/0" and isinstance(trial["success"], bool)
    assert trial["criterion"] is None or {"success", "value", "text"} <= set(trial["criterion"])
    assert trial["phases"] and trial["final_poses"] and trial["execution"]["seconds"] > 0
    assert scene["control"]["key"] == f"{key}/000/control"
    row = results["table"]["rows"][0]
    assert row["task"] == key and row["runs"] == 1 and row["mean"] in (0.0, 1.0)
    assert not (out / "results.json.journal").exists()


@pytest.mark.slow
def test_a_run_replays_exactly_with_rapidc_run(rapidc, tmp_path: Path):
    out = tmp_path / "bench"
    assert rapidc("bench", "nonprehensile", "--tasks", "P1", "--scenes", 1, "--trials", 1,
                  "--out", out, *BUDGET, "-q").code == 0
    (trial,) = _results(out)["scenes"][0]["trials"]
    trace = tmp_path / "trace.json"
    replay = rapidc("run", OWN.with_suffix(".rapid"), "--scene", trial["scene_file"], "--best",
                    "--seed", trial["seed"], *BUDGET, "--trace", trace)
    assert replay.code in (0, 1), replay.err
    assert json.loads(trace.read_text())["final_poses"] == trial["final_poses"]


@pytest.mark.slow
def test_one_job_two_jobs_and_a_local_cluster_give_the_same_results(rapidc, tmp_path: Path):
    args = ("bench", "nonprehensile", "--tasks", "P1", "--scenes", 2, "--trials", 1, *BUDGET,
            "-q")
    ways = {"one": (), "two": ("--jobs", 2), "cluster": ("--cluster", "local:2")}
    for name, how in ways.items():
        run = rapidc(*args, "--out", tmp_path / name, *how)
        assert run.code == 0, f"{name}: {run.err}"
    first = _results(tmp_path / "one")
    for name in ("two", "cluster"):
        other = _results(tmp_path / name)
        for a, b in zip(first["scenes"], other["scenes"], strict=True):
            assert [_same(t) for t in [*a["trials"], a["control"]]] == \
                [_same(t) for t in [*b["trials"], b["control"]]], name
        assert (tmp_path / "one" / "scenes" / "p1-001.yaml").read_text() == \
            (tmp_path / name / "scenes" / "p1-001.yaml").read_text()
        assert first["table"]["rows"][0]["mean"] == other["table"]["rows"][0]["mean"]


@pytest.mark.slow
def test_an_interrupted_run_resumes_keeping_what_it_finished(rapidc, tmp_path: Path,
                                                            monkeypatch):
    from rapid_dsl.bench.nonprehensile.harness import BenchRunner

    real, calls = BenchRunner.run, []

    def interrupted(self, key, trial):
        calls.append(key)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(self, key, trial)

    out = tmp_path / "bench"
    args = ("bench", "nonprehensile", "--tasks", "P1", "--scenes", 2, "--trials", 1, *BUDGET,
            "--out", out)
    monkeypatch.setattr(BenchRunner, "run", interrupted)
    stopped = rapidc(*args)
    assert stopped.code == 130 and "--resume" in stopped.err
    partial = _results(out)
    assert partial["complete"] is False
    kept = {t["key"]: t for s in partial["scenes"] for t in [*s["trials"], s["control"]] if t}
    assert sorted(kept) == ["P1/000/0", "P1/000/control"]
    journal = (out / "results.json.journal").read_text().splitlines()
    assert len(journal) == 3 and json.loads(journal[0])["format"].startswith("rapidc-bench")
    # a torn last line (the run was killed while writing) is dropped
    (out / "results.json.journal").write_text("\n".join(journal) + '\n{"key": "P1/00', "utf-8")
    monkeypatch.setattr(BenchRunner, "run", real)
    resumed = rapidc(*args, "--resume")
    assert resumed.code == 0, resumed.err
    done = _results(out)
    assert done["complete"] is True
    records = {t["key"]: t for s in done["scenes"] for t in [*s["trials"], s["control"]]}
    assert sorted(records) == ["P1/000/0", "P1/000/control", "P1/001/0", "P1/001/control"]
    for key, record in kept.items():   # not run again: the same record, timing included
        assert records[key] == record
    assert not (out / "results.json.journal").exists()
    other = rapidc(*args[:-2], "--out", out, "--resume", "--trials", 2)
    assert other.code == 2 and "other tasks, programs or settings" in other.err


def test_bad_input_is_exit_2_with_a_clear_message(rapidc, tmp_path: Path):
    unknown = rapidc("bench", "nonprehensile", "--tasks", "T9", "--out", tmp_path / "a")
    assert unknown.code == 2 and "no task `T9`" in unknown.err
    zero = rapidc("bench", "nonprehensile", "--scenes", 0)
    assert zero.code == 2 and "--scenes" in zero.err
    afile = tmp_path / "afile"
    afile.write_text("x")
    bad_out = rapidc("bench", "nonprehensile", "--tasks", "P1", "--out", afile)
    assert bad_out.code == 2 and "not a folder" in bad_out.err
    both = rapidc("bench", "nonprehensile", "--jobs", 2, "--cluster", "local:2")
    assert both.code == 2 and "choose one" in both.err
    twice = rapidc("bench", "nonprehensile", "--tasks", "P1,p1")
    assert twice.code == 2 and "listed twice" in twice.err
    nothing = rapidc("bench", "nonprehensile", "--tasks", "P1", "--out", tmp_path / "b",
                     "--resume")
    assert nothing.code == 2 and "holds no earlier run" in nothing.err
    folder_json = rapidc("bench", "nonprehensile", "--tasks", "P1", "--out", tmp_path / "c",
                         "--json", tmp_path)
    assert folder_json.code == 2 and "--json: cannot write" in folder_json.err
    assert not (tmp_path / "c").exists()   # refused before anything ran
    cluster = rapidc("bench", "nonprehensile", "--cluster", "nowhere")
    assert cluster.code == 2 and "--cluster nowhere" in cluster.err
    assert "Traceback" not in unknown.err + bad_out.err + nothing.err


def test_the_robot_option_rewrites_the_scenes(rapidc, tmp_path: Path):
    run = rapidc("bench", "nonprehensile", "--tasks", "P1", "--scenes", 1, "--trials", 1,
                 "--robot", "floating_gripper", "--out", tmp_path, "--samples", 4,
                 "--iterations", 1, "-q", "--format", "json")
    assert run.code == 0, run.err
    assert load_scene(tmp_path / "scenes" / "p1-000.yaml").robot == "floating_gripper"
    assert _results(tmp_path)["settings"]["robot"] == "floating_gripper"
    assert json.loads(run.out) == _results(tmp_path)   # --format json: the results on stdout
