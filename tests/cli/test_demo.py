"""`rapidc demo analyze`: the table and JSON of a recorded track, the skeleton (which `rapidc
check` accepts), and bad tracks of every kind refused with exit status 2 and where the problem is.
"""

from __future__ import annotations

import copy
import json
import os
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rapid_dsl.commands.demo_skeleton import skeleton
from rapid_dsl.frontend.driver import check_text
from rapid_dsl.language.files import MAX_INPUT_BYTES
from rapid_dsl.runtime.demonstrations.analysis import analyze_track
from rapid_dsl.runtime.demonstrations.track import dump_track

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "runtime"))
from demo_tracks import grasp, lift, pause, slide, synthetic, turn  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
FLIP = ROOT / "examples" / "tracks" / "flip_box.json"
PICK = ROOT / "examples" / "tracks" / "pick_and_place.json"


def test_the_table_lists_each_phase_with_its_effect_and_argument(rapidc) -> None:
    run = rapidc("demo", "analyze", FLIP)
    assert run.code == 0, run.err
    lines = run.out.splitlines()
    assert lines[0].startswith(f"{FLIP}: 2 phases in ") and "hand gripper" in lines[0]
    assert lines[1].split() == ["#", "phase", "object", "time", "displacement", "distance",
                                "rotation", "lift", "relations", "argument"]
    push, flip = lines[2], lines[3]
    assert push.split()[:3] == ["1", "push", "box"] and "displacement=[7cm, 0cm, 0cm]" in push
    assert flip.split()[:3] == ["2", "flip", "box"] and "angle=89.4deg" in flip
    assert "about [0, 1, 0]" in flip and "on table, at wall" in flip


def test_json_is_one_object_with_the_phases_their_effects_and_the_thresholds(rapidc) -> None:
    run = rapidc("demo", "analyze", PICK, "--format", "json")
    assert run.code == 0, run.err
    analysis = json.loads(run.out)
    assert analysis["format"] == "rapidc-demo/1" and analysis["track"] == str(PICK)
    assert [p["kind"] for p in analysis["phases"]] == ["grasp", "lift", "move"]
    lifted = analysis["phases"][1]
    assert lifted["argument_text"] == {"rise": "10cm"} and lifted["argument_units"] == \
        {"rise": "m"}
    assert set(lifted["effect"]) == {"displacement", "distance", "horizontal_distance",
                                     "rotation_angle", "rotation_axis", "lift_height",
                                     "peak_lift_height"}
    assert set(analysis["units"]) >= set(lifted["effect"])
    assert analysis["thresholds"]["speed_on"] == 0.02
    assert analysis["threshold_units"]["speed_on"] == "m/s"
    assert json.loads(run.out) == analyze_track(PICK)   # the CLI prints analyze_track's result


@pytest.mark.parametrize("track", [FLIP, PICK], ids=["flip_box", "pick_and_place"])
def test_the_skeleton_checks_clean(rapidc, tmp_path: Path, track: Path) -> None:
    out = tmp_path / "skeleton.rapid"
    run = rapidc("demo", "analyze", track, "--skeleton", out)
    assert run.code == 0, run.err
    assert f"wrote {out}" in run.err
    checked = rapidc("check", out)
    assert checked.code == 0 and checked.out == "", checked.out
    assert rapidc("fmt", "--check", out).code == 0     # written in the canonical layout
    text = out.read_text()
    if track == FLIP:
        assert "use stdlib.{push, flip}" in text
        assert "roles { box: Object, table: Surface, wall: Fixture, hand: Manipulator }" in text
        assert "displacement = [7cm, 0cm, 0cm]" in text and "angle = 89.4deg" in text
    else:
        assert "approach = [0, 0, -1]" in text and "rise = 10cm" in text


def test_a_measured_value_outside_a_params_range_is_clamped_with_a_note(tmp_path: Path,
                                                                       rapidc) -> None:
    """A 40 cm lift: `lift`'s rise is at most 30 cm."""
    track = tmp_path / "high.json"
    track.write_text(dump_track(synthetic([pause(1), grasp(), pause(0.5), lift(0.4, 2.5),
                                           pause(1)])))
    run = rapidc("demo", "analyze", track, "--skeleton", tmp_path / "high.rapid")
    assert run.code == 0, run.err
    text = (tmp_path / "high.rapid").read_text()
    assert "rise = 30cm" in text and "# measured 40cm, outside the range [1cm, 30cm]" in text
    assert rapidc("check", tmp_path / "high.rapid").code == 0


def test_no_skeleton_from_a_track_without_a_primitives_effect(tmp_path: Path, rapidc) -> None:
    track = tmp_path / "still.json"
    track.write_text(dump_track(synthetic([pause(2)])))
    run = rapidc("demo", "analyze", track, "--skeleton", tmp_path / "still.rapid")
    assert run.code == 1 and "no phase of the track shows the effect" in run.err
    assert "0 phases" in run.out and not (tmp_path / "still.rapid").exists()


def test_the_skeleton_is_never_written_over_the_track_or_through_a_link(tmp_path: Path,
                                                                       rapidc) -> None:
    track = tmp_path / "t.json"
    track.write_text(FLIP.read_text())
    run = rapidc("demo", "analyze", track, "--skeleton", track)
    assert run.code == 2 and "is an input of this command; refusing to overwrite it" in run.err
    assert track.read_text() == FLIP.read_text()
    (tmp_path / "victim").write_text("keep")
    (tmp_path / "link.rapid").symlink_to(tmp_path / "victim")
    run = rapidc("demo", "analyze", track, "--skeleton", tmp_path / "link.rapid")
    assert run.code == 2 and "is a symbolic link" in run.err
    assert (tmp_path / "victim").read_text() == "keep"


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(names=st.lists(st.text(min_size=1, max_size=20), min_size=3, max_size=3, unique=True))
def test_any_entity_names_give_a_skeleton_that_checks_clean(names) -> None:
    """Role names are made from entity names: keywords, builtins, digits, quotes, line breaks
    and other scripts included, the skeleton still checks (and says which entity is which only
    in comments, escaped)."""
    data = synthetic([pause(1), slide(0.1, 0.0), pause(0.6), turn((0, 0, 1), 60), pause(1)])
    renames = dict(zip(("table", "box", "gripper"), names, strict=True))
    for entity in data["entities"]:
        entity["name"] = renames[entity["name"]]
    data["hand"] = renames["gripper"]
    for frame in data["frames"]:
        frame["objects"] = {renames["box"]: frame["objects"]["box"]}
    text = skeleton(analyze_track(data))
    result = check_text(text, "skeleton.rapid")
    assert result.ok, (text, [d.message for d in result.diagnostics])
    assert all(line.isascii() and line.isprintable() for line in text.splitlines())


@pytest.mark.parametrize("name", ["on", "phase", "start", "push_1", "2box", "__x", "up", "pi"])
def test_names_the_language_reserves_become_other_role_names(name: str) -> None:
    data = synthetic([pause(1), slide(0.1, 0.0), pause(1)])
    data["entities"][1]["name"] = name
    for frame in data["frames"]:
        frame["objects"] = {name: frame["objects"]["box"]}
    text = skeleton(analyze_track(data))
    assert check_text(text, "skeleton.rapid").ok, text


# --- bad input -----------------------------------------------------------------------------------

def _track_text(change) -> str:
    data = json.loads(FLIP.read_text())
    change(data)
    return json.dumps(data, indent=1)


@pytest.mark.parametrize(("text", "expected"), [
    (_track_text(lambda d: d["frames"][5]["hand"].update(opening=None)),
     "$.frames[5].hand.opening: Input should be a valid number"),
    (_track_text(lambda d: d["frames"][9]["objects"]["box"].pop("quat")),
     "$.frames[9].objects.box.quat: required field is missing"),
    (_track_text(lambda d: d["frames"][7].update(t=0.0)),
     "$.frames[7].t: 0 s is not after the previous frame's 0.24 s"),
    (_track_text(lambda d: d.pop("entities")), "$.entities: required field is missing"),
    ('{"format": "rapidc-track/1",}', "1:29: error: not JSON: Expecting property name"),
    ("", "1:1: error: not JSON: Expecting value"),
])
def test_a_bad_track_is_exit_status_2_with_where_and_why(text: str, expected: str, tmp_path,
                                                         rapidc) -> None:
    path = tmp_path / "bad.json"
    path.write_text(text)
    run = rapidc("demo", "analyze", path)
    assert run.code == 2 and run.out == ""
    assert expected in run.err, run.err
    assert run.err.startswith(f"{path}:")


def test_files_that_cannot_be_tracks_are_refused(tmp_path: Path, rapidc) -> None:
    assert "cannot read the track: no such file" in rapidc("demo", "analyze",
                                                           tmp_path / "none.json").err
    assert "cannot read the track: is a folder" in rapidc("demo", "analyze", tmp_path).err
    big = tmp_path / "big.json"
    with big.open("wb") as f:
        f.truncate(MAX_INPUT_BYTES + 1)
    run = rapidc("demo", "analyze", big)
    assert run.code == 2 and "larger than the input limit of 10 MiB" in run.err
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    run = rapidc("demo", "analyze", fifo)
    assert run.code == 2 and "not a regular file" in run.err
    (tmp_path / "latin1.json").write_bytes(b'{"format": "\xe9"}')
    assert "not UTF-8 text" in rapidc("demo", "analyze", tmp_path / "latin1.json").err


def test_demo_schema_prints_the_shipped_schema(rapidc) -> None:
    from rapid_dsl.runtime.demonstrations.track import schema

    run = rapidc("demo", "schema")
    assert run.code == 0 and json.loads(run.out) == schema()


def test_usage_errors(rapidc) -> None:
    assert rapidc("demo").code == 2
    run = rapidc("demo", "analyze", FLIP, "--format", "github")
    assert run.code == 2 and "demo analyze prints `--format human` or `json`" in run.err
    assert rapidc("demo", "analyze", "").code == 2


SMALL = json.loads(dump_track(synthetic([pause(0.3), slide(0.05, 0.0, duration=0.4),
                                         pause(0.3)], rate=10.0)))
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner,
                                                                max_size=3), max_leaves=6)


@pytest.mark.slow
@settings(max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(changes=st.lists(st.tuples(st.integers(0, 10_000), JSON_VALUES), min_size=1, max_size=3))
def test_any_damaged_track_is_analyzed_or_refused_never_an_internal_error(changes, tmp_path,
                                                                          rapidc) -> None:
    data = copy.deepcopy(SMALL)
    for where, value in changes:
        paths = list(_paths(data))
        path = paths[where % len(paths)]
        if not path:
            data = value
            continue
        parent = data
        for part in path[:-1]:
            parent = parent[part]
        parent[path[-1]] = value
    track = tmp_path / "damaged.json"
    track.write_text(json.dumps(data))
    run = rapidc("demo", "analyze", track, "--format", "json")
    assert run.code in (0, 2), run.err
    assert "internal error" not in run.err and "Traceback" not in run.err
    if run.code == 0:
        json.loads(run.out)
    else:
        assert run.err.startswith(f"{track}:")


def _paths(value, prefix=()):
    yield prefix
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _paths(item, (*prefix, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from _paths(item, (*prefix, i))
