"""The track format (runtime/demonstrations/track.py): the shipped JSON Schema is the models' own,
what the schema allows the models allow, and every invalid track is refused with the JSON path of
the problem and, read from text, its line and column."""

from __future__ import annotations

import copy
import json
import math

import jsonschema
import pytest
from demo_tracks import pause, slide, synthetic
from hypothesis import given, settings
from hypothesis import strategies as st

from rapid_dsl.language.safe_json import json_path, locate
from rapid_dsl.runtime.demonstrations.track import (
    SCHEMA,
    TrackError,
    dump_track,
    generated_schema,
    parse_track,
    schema,
    validate_track,
)

TRACK = synthetic([pause(0.2), slide(0.05, 0.0, duration=0.2)], rate=10.0)


def problems(text: str) -> list[str]:
    with pytest.raises(TrackError) as error:
        parse_track(text, "t.json")
    return [p.labelled() for p in error.value.problems]


def test_the_shipped_schema_is_the_models_schema() -> None:
    assert json.loads(SCHEMA.read_text(encoding="utf-8")) == generated_schema(), (
        "runtime/demonstrations/track.schema.json is stale: write generated_schema() to it")
    jsonschema.Draft202012Validator.check_schema(schema())


def test_a_dumped_track_reads_back_and_puts_one_frame_on_a_line() -> None:
    text = dump_track(TRACK)
    track = parse_track(text)
    assert len(track.frames) == len(TRACK["frames"]) and track.hand == "gripper"
    assert sum(line.lstrip().startswith('{"t": ') for line in text.splitlines()) \
        == len(TRACK["frames"])
    jsonschema.validate(json.loads(text), schema(), cls=jsonschema.Draft202012Validator)


def _with(change) -> str:
    data = copy.deepcopy(TRACK)
    change(data)
    return dump_track(data)


CASES = [
    (lambda d: d["frames"][2]["hand"].update(opening=-0.01),
     "$.frames[2].hand.opening", "greater than or equal to 0"),
    (lambda d: d["frames"][1].update(t=d["frames"][0]["t"]),
     "$.frames[1].t", "is not after the previous frame's"),
    (lambda d: d["frames"][3]["objects"]["box"].update(quat=[1.0, 1.0, 0.0, 0.0]),
     "$.frames[3].objects.box.quat", "not a unit quaternion"),
    (lambda d: d["frames"][3]["objects"]["box"].update(position=[0.0, "0", 0.0]),
     "$.frames[3].objects.box.position[1]", "valid number"),
    (lambda d: d["frames"][0]["objects"].pop("box"), "$.frames[0].objects",
     "the pose of `box` is missing"),
    (lambda d: d["frames"][0]["objects"].update({"cup one": d["frames"][0]["objects"]["box"]}),
     '$.frames[0].objects["cup one"]', "not an Object entity"),
    (lambda d: d["frames"][4].pop("hand"), "$.frames[4].hand", "required field is missing"),
    (lambda d: d.update(colour="red"), "$.colour", "unknown field"),
    (lambda d: d["entities"][2].update(name="table"), "$.entities[2].name",
     "duplicate entity name `table`"),
    (lambda d: d["entities"][0].pop("pose"), "$.entities[0]", "a Surface needs its `pose`"),
    (lambda d: d["entities"][1].update(kind="Fixture", pose=d["entities"][0]["pose"]),
     "$.entities", "at least one entity of kind Object"),
    (lambda d: d.update(hand="box"), "$.entities[1].kind", "must be Manipulator"),
    (lambda d: d.update(format="rapidc-track/2"), "$.format", "'rapidc-track/1'"),
    (lambda d: d.update(frames=[]), "$.frames", "at least 1 item"),
    (lambda d: d["frames"][0].update(t=True), "$.frames[0].t", "valid number"),
    (lambda d: d["entities"][1].update(name="b\ud800"), "$.entities[1].name",
     "not text: it holds a lone surrogate"),
    (lambda d: d["frames"][0]["objects"].update({"\ud800": d["frames"][0]["objects"]["box"]}),
     "$.frames[0].objects",   # the reader refuses it: no model sees the key
     "a key is not text: it holds a lone surrogate"),
]


@pytest.mark.parametrize(("change", "path", "message"), CASES)
def test_an_invalid_track_names_the_json_path_line_and_column(change, path, message) -> None:
    text = _with(change)
    found = problems(text)
    matching = [p for p in found if f": error: {path}: " in p]
    assert matching and message in matching[0], found
    line, column = (int(x) for x in matching[0].split(":")[1:3])
    assert 1 <= line <= text.count("\n") + 1 and column >= 1


def test_the_line_and_column_are_where_the_value_is_written() -> None:
    text = _with(lambda d: d["frames"][2]["hand"].update(opening=-0.01))
    [problem] = problems(text)
    line, column = (int(x) for x in problem.split(":")[1:3])
    assert text.splitlines()[line - 1][column - 1:].startswith('"opening": -0.01')


def test_numbers_that_are_not_finite_are_refused_where_they_are() -> None:
    text = dump_track(TRACK).replace('"t": 0.1,', '"t": NaN,', 1)
    line = 1 + text[:text.index("NaN")].count("\n")
    column = text.index("NaN") - text.rfind("\n", 0, text.index("NaN"))
    [problem] = problems(text)
    assert problem == f"t.json:{line}:{column}: error: `NaN` is not a finite number"
    [problem] = problems(dump_track(TRACK).replace('"t": 0.0,', '"t": 1e999,', 1))
    assert "1e999" not in problem and "too large to be finite" in problem


@pytest.mark.parametrize(("text", "message"), [
    ("", "not JSON: Expecting value"), ('{"format": ', "not JSON"), ("[]", "a JSON object"),
    ("[" * 100_000, "nested too deeply"), ("1" * 5000, "a number has too many digits"),
    ('"\\ud800"', "$: not text: it holds a lone surrogate"),
])
def test_text_that_is_not_a_track_object_is_refused(text: str, message: str) -> None:
    [problem] = problems(text)
    assert problem.startswith("t.json:1:") and message in problem


def test_many_problems_are_listed_up_to_twenty_with_a_count_of_the_rest() -> None:
    data = synthetic([pause(2.0)])
    for frame in data["frames"]:
        frame["hand"]["opening"] = -1.0
    with pytest.raises(TrackError) as error:
        parse_track(dump_track(data), "t.json")
    assert len(error.value.problems) == 20 and error.value.more == len(data["frames"]) - 20
    assert str(error.value).endswith(f"... and {error.value.more} more problems")


def test_a_pose_missing_from_every_frame_is_one_problem_with_a_count() -> None:
    data = copy.deepcopy(TRACK)
    data["entities"][1]["name"] = "crate"
    with pytest.raises(TrackError) as error:
        validate_track(data)
    count = len(data["frames"]) - 1
    assert [p.labelled() for p in error.value.problems] == [
        f"<track>: error: $.frames[0].objects: the pose of `crate` is missing (and in {count} "
        "more frames)",
        f"<track>: error: $.frames[0].objects.box: not an Object entity of the track (and in "
        f"{count} more frames)"]


def test_parsed_data_is_checked_alike_without_lines() -> None:
    data = copy.deepcopy(TRACK)
    data["frames"][0]["t"] = "soon"
    with pytest.raises(TrackError) as error:
        validate_track(data)
    assert str(error.value) == "<track>: error: $.frames[0].t: Input should be a valid number"


def test_json_paths_quote_keys_that_are_not_plain_names() -> None:
    assert json_path(("frames", 3, "objects", "box")) == "$.frames[3].objects.box"
    assert json_path(("objects", 'a "b"\n')) == '$.objects["a \\"b\\"\\n"]'


def test_locate_finds_keys_items_and_the_object_of_a_missing_field() -> None:
    text = '{\n  "a": [1, {"b": 2}],\n  "c": {"d": [3, 4]}\n}'
    places = locate(text, [("a", 1, "b"), ("c", "d", 1), ("c", "missing"), ()])
    assert places == {("a", 1, "b"): (2, 13), ("c", "d", 1): (3, 18), ("c", "missing"): (3, 3),
                      (): (1, 1)}


# --- the schema and the models agree ---------------------------------------------------------

def _mutations():
    leaves = st.one_of(st.none(), st.booleans(), st.integers(-5, 5),
                       st.floats(allow_nan=False, allow_infinity=False, width=32),
                       st.text(max_size=3), st.just([]), st.just({}))
    return st.lists(st.tuples(st.integers(0, 10_000), leaves), min_size=1, max_size=3)


def _paths(value, prefix=()):
    yield prefix
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _paths(item, (*prefix, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from _paths(item, (*prefix, i))


@settings(max_examples=150, deadline=None)
@given(changes=_mutations())
def test_what_the_models_accept_the_schema_accepts(changes) -> None:
    """The schema is not stricter than reading: a track that reads is valid by the schema (the
    schema cannot say everything reading checks, so the converse does not hold)."""
    data = copy.deepcopy(TRACK)
    for where, value in changes:
        paths = [p for p in _paths(data) if p]
        path = paths[where % len(paths)]
        parent = data
        for part in path[:-1]:
            parent = parent[part]
        parent[path[-1]] = value
    try:
        validate_track(data)
    except TrackError:
        return
    jsonschema.validate(data, schema(), cls=jsonschema.Draft202012Validator)


def test_a_value_within_the_bounds_reads() -> None:
    data = copy.deepcopy(TRACK)
    data["frames"][0]["t"] = -1e9
    data["frames"][0]["objects"]["box"]["quat"] = [math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)]
    assert validate_track(data).frames[0].t == -1e9
