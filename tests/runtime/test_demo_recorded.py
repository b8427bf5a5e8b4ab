"""`rapidc run --track` of a real push-then-flip run (examples/flip_box.rapid), and the analysis of
that track against the run's own trace: its final poses, the push's miss and the flip's angle.
The track is written like the other outputs: atomically, never through a link or over an input.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from demo_tracks import angle_between

from rapid_dsl.cli import main
from rapid_dsl.runtime.demonstrations.analysis import analyze_track
from rapid_dsl.runtime.demonstrations.signals import rotation_between
from rapid_dsl.runtime.demonstrations.track import load_track, schema

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "run"
CM, DEG = 0.01, math.radians(1)
FAST = ["--entry", "shove", "--arg", "displacement=[6cm, 0cm, 0cm]", "--samples", "8",
        "--iterations", "1", "--quiet"]


@pytest.fixture(scope="module")
def flip_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, dict, dict]:
    """(track, trace, analysis) of examples/flip_box.rapid on its scene, default budgets."""
    out = tmp_path_factory.mktemp("flip")
    status = main(["run", str(ROOT / "examples" / "flip_box.rapid"), "--scene",
                   str(ROOT / "examples" / "scenes" / "flip_box.yaml"), "--quiet",
                   "--trace", str(out / "trace.json"), "--track", str(out / "track.json")])
    assert status == 0
    track = json.loads((out / "track.json").read_text())
    trace = json.loads((out / "trace.json").read_text())
    return track, trace, analyze_track(out / "track.json")


@pytest.mark.slow
def test_the_track_follows_its_schema_and_ends_in_the_runs_final_poses(flip_run) -> None:
    track, trace, _ = flip_run
    jsonschema.validate(track, schema(), cls=jsonschema.Draft202012Validator)
    last = track["frames"][-1]
    for name, pose in last["objects"].items():
        final = trace["final_poses"][name]
        assert np.allclose(pose["position"], final["position"], atol=1e-4)
        assert np.allclose(pose["quat"], final["quat"], atol=1e-5)
    assert [(p["name"], p["primitive"]) for p in track["phases"]] == [("approach", "push"),
                                                                     ("tip", "flip")]
    times = [f["t"] for f in track["frames"]]
    assert times == sorted(set(times)) and times[0] == 0.0
    assert track["phases"][-1]["end"] == times[-1]


@pytest.mark.slow
def test_the_analysis_finds_the_push_then_the_flip_within_their_phases(flip_run) -> None:
    track, _, analysis = flip_run
    pushed, flipped = analysis["phases"]
    assert (pushed["kind"], flipped["kind"]) == ("push", "flip")
    for found, ran in zip((pushed, flipped), track["phases"], strict=True):
        assert ran["start"] <= found["start"] < found["end"] <= ran["end"]
        assert found["object"] == "box" and found["support"] == "table"
    assert flipped["fixture"] == "wall"
    assert angle_between(flipped["effect"]["rotation_axis"], (0, 1, 0)) <= 3 * DEG


@pytest.mark.slow
def test_the_measured_effects_agree_with_the_runs_own_clauses(flip_run) -> None:
    """The push's measured displacement misses its argument by the run's `miss`, and the flip's
    angle misses 90deg by the run's `abs(turned - angle)`: within 1 cm and 3 deg."""
    _, trace, analysis = flip_run
    pushed, flipped = analysis["phases"]
    approach, tip = trace["phases"]
    miss = next(c["value"] for c in approach["success"] if c["text"] == "miss < 2cm")
    off = np.linalg.norm(np.subtract(pushed["arguments"]["displacement"][:2],
                                     approach["arguments"]["displacement"][:2]))
    assert abs(off - miss) <= 1 * CM
    angle_miss = next(c["value"] for c in tip["success"] if c["text"].startswith("abs(turned"))
    assert abs(abs(flipped["arguments"]["angle"] - tip["arguments"]["angle"]) - angle_miss) \
        <= 3 * DEG


def test_the_phases_compose_to_the_runs_final_pose(flip_run) -> None:
    """Start pose + each phase's displacement and rotation = the final pose of the trace."""
    track, trace, analysis = flip_run
    start = track["frames"][0]["objects"]["box"]
    position = np.array(start["position"])
    for phase in analysis["phases"]:
        position = position + phase["effect"]["displacement"]
    final = trace["final_poses"]["box"]
    assert np.linalg.norm(position - final["position"]) <= 1 * CM
    angle, _ = rotation_between(np.array(analysis["phases"][-1]["after"]["quat"]),
                                np.array(final["quat"]))
    assert angle <= 3 * DEG
    turned, _ = rotation_between(np.array(start["quat"]), np.array(final["quat"]))
    total = sum(p["effect"]["rotation_angle"] for p in analysis["phases"])
    assert abs(total - turned) <= 3 * DEG      # both turns are about the wall's edge


def test_the_shipped_example_tracks_are_valid_and_analyze_as_their_programs_ran() -> None:
    kinds = {"flip_box.json": ["push", "flip"], "pick_and_place.json": ["grasp", "lift", "move"]}
    for name, expected in kinds.items():
        path = ROOT / "examples" / "tracks" / name
        jsonschema.validate(json.loads(path.read_text()), schema(),
                            cls=jsonschema.Draft202012Validator)
        assert [p["kind"] for p in analyze_track(path)["phases"]] == expected
        assert [p.primitive for p in load_track(path).phases] == expected
        assert path.stat().st_size < 64 * 1024


# --- writing it --------------------------------------------------------------------------------

@pytest.fixture
def project(tmp_path: Path) -> Path:
    shutil.copy(DATA / "shove.rapid", tmp_path / "shove.rapid")
    shutil.copy(DATA / "tabletop.yaml", tmp_path / "tabletop.yaml")
    return tmp_path


def run(project: Path, capsys, *extra: object) -> tuple[int, str]:
    status = main(["run", str(project / "shove.rapid"), "--scene", str(project / "tabletop.yaml"),
                   *FAST, *map(str, extra)])
    return status, capsys.readouterr().err


def test_a_primitive_runs_track_is_written_atomically_and_replaces_an_old_one(project: Path,
                                                                           capsys) -> None:
    (project / "out").mkdir()
    (project / "out" / "track.json").write_text("old")
    status, err = run(project, capsys, "--track", project / "out" / "track.json")
    assert status == 0, err
    assert [p.name for p in (project / "out").iterdir()] == ["track.json"]
    track = load_track(project / "out" / "track.json")
    assert [p.name for p in track.phases] == ["shove"]
    assert track.source is not None and track.source.outcome == "succeeded"


def test_the_track_is_never_written_through_a_symlink_or_over_an_input(project: Path,
                                                                      capsys) -> None:
    victim = project / "victim.txt"
    victim.write_text("keep me")
    (project / "track.json").symlink_to(victim)
    status, err = run(project, capsys, "--track", project / "track.json")
    assert status == 2 and f"cannot write track {project / 'track.json'}: is a symbolic link" \
        in err
    assert victim.read_text() == "keep me"
    scene = (project / "tabletop.yaml").read_text()
    status, err = run(project, capsys, "--track", project / "tabletop.yaml")
    assert status == 2 and "is an input of this command; refusing to overwrite it" in err
    assert (project / "tabletop.yaml").read_text() == scene


def test_the_track_and_the_trace_may_not_be_one_file(project: Path, capsys) -> None:
    status, err = run(project, capsys, "--track", project / "out.json", "--trace",
                      project / "out.json")
    assert status == 2 and "--track and --trace name the same file" in err
    assert not (project / "out.json").exists()


def test_a_phase_that_fails_before_moving_has_no_span_in_the_track(project: Path,
                                                                  capsys) -> None:
    """shove_then_reach: `hover`'s argument is out of range, so only `push` moved."""
    status = main(["run", str(project / "shove.rapid"), "--scene", str(project / "tabletop.yaml"),
                   "--entry", "shove_then_reach", "--samples", "8", "--iterations", "1",
                   "--quiet", "--track", str(project / "track.json")])
    capsys.readouterr()
    assert status == 1
    assert [p.name for p in load_track(project / "track.json").phases] == ["push"]


def test_a_rejected_run_tracks_its_start_state_alone(project: Path, capsys) -> None:
    """A filter rejects the scene (verdicts.rapid `tall_boxes_only`): nothing moved, so the
    track holds one frame, the start state, and no phases."""
    shutil.copy(DATA / "verdicts.rapid", project / "verdicts.rapid")
    status = main(["run", str(project / "verdicts.rapid"), "--scene",
                   str(project / "tabletop.yaml"), "--entry", "tall_boxes_only", "--quiet",
                   "--track", str(project / "track.json")])
    assert "REJECTED" in capsys.readouterr().out
    track = load_track(project / "track.json")
    assert status == 1 and len(track.frames) == 1 and track.frames[0].t == 0.0
    assert track.phases == [] and track.source is not None and track.source.outcome == "rejected"
    assert analyze_track(track)["phases"] == []


@pytest.mark.slow
def test_the_skeleton_of_the_flip_track_runs_the_push_and_the_flip_again(tmp_path: Path,
                                                                        capsys) -> None:
    """The loop closes: the skeleton made from the example track, run on the scene the track
    was recorded in, succeeds with the measured effects as its arguments."""
    skeleton = tmp_path / "again.rapid"
    assert main(["demo", "analyze", str(ROOT / "examples" / "tracks" / "flip_box.json"),
                 "--skeleton", str(skeleton), "--quiet"]) == 0
    status = main(["run", str(skeleton), "--scene",
                   str(ROOT / "examples" / "scenes" / "flip_box.yaml"), "--quiet",
                   "--trace", str(tmp_path / "trace.json")])
    assert status == 0, capsys.readouterr()
    trace = json.loads((tmp_path / "trace.json").read_text())
    assert [(p["primitive"], p["status"]) for p in trace["phases"]] == [("push", "succeeded"),
                                                                         ("flip", "succeeded")]
