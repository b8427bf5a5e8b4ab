"""The track format: an execution's object and hand poses over time (docs/demos.md).

A track is one JSON object: the entities (name, kind, shape, extents; the pose of the static
ones), the name of the hand, and per frame the time, every Object's pose (position, quaternion
w x y z) and the hand's pose and finger opening. SI units throughout (s, m). `rapidc run --track`
writes one (runtime/demonstrations/track_record.py) and `rapidc demo analyze` reads one
(runtime/demonstrations/analysis.py); a demonstration recorded another way (a pose tracker on a
video) can be written in the same form.

The pydantic models below are the one definition of the format: the JSON Schema shipped beside
this module (track.schema.json, `schema()`) is generated from them (a test keeps the two equal),
and reading validates against them. The rules a JSON Schema cannot state (entity names unique,
every frame holding exactly the Objects' poses, times strictly increasing, unit quaternions) are
checked here too. Every problem names the JSON path of the value (`$.frames[3].hand.opening`) and,
for a file, its line and column.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError

from rapid_dsl.language.files import FileProblem, read_text
from rapid_dsl.language.safe_json import (
    LONE_SURROGATE,
    JsonError,
    JsonProblem,
    Loc,
    loads,
    locate,
    problem_of,
    problems,
)

SCHEMA = Path(__file__).with_name("track.schema.json")
FORMAT = "rapidc-track/1"
MAX_FRAMES = 100_000        # 10 MiB of input holds about 50,000 one-object frames
MAX_ENTITIES = 66           # a scene's 64 objects, the gripper and the floor
MAX_NAME = 64               # characters, as scene names
MAX_TEXT = 1024             # characters of a source field
MAX_COORDINATE = 1000.0     # m, |x|, |y|, |z|
MAX_TIME = 1e10             # s, |t| (a clock's epoch seconds fit)
MAX_EXTENT = 100.0          # m
MAX_OPENING = 1.0           # m
UNIT_TOLERANCE = 0.01       # a quaternion's norm must be within 1 % of 1


# --- the format --------------------------------------------------------------------------------

def _unit(quat: list[float]) -> list[float]:
    norm = math.sqrt(sum(q * q for q in quat))
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        raise ValueError(f"not a unit quaternion (w x y z): its norm is {norm:.4g}")
    return [q / norm for q in quat]


Coordinate = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_COORDINATE,
                                    le=MAX_COORDINATE)]
Extent = Annotated[float, Field(allow_inf_nan=False, ge=0.0, le=MAX_EXTENT)]
Vec3 = Annotated[list[Coordinate], Field(min_length=3, max_length=3)]
Quat = Annotated[list[Annotated[float, Field(allow_inf_nan=False, ge=-1.1, le=1.1)]],
                 Field(min_length=4, max_length=4,
                       description="orientation as a unit quaternion w x y z"),
                 AfterValidator(_unit)]
def _text(text: str) -> str:
    if any(0xD800 <= ord(c) <= 0xDFFF for c in text):
        raise ValueError(LONE_SURROGATE)
    return text


Name = Annotated[str, Field(min_length=1, max_length=MAX_NAME), AfterValidator(_text)]
Text = Annotated[str, Field(max_length=MAX_TEXT), AfterValidator(_text)]
Time = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_TIME, le=MAX_TIME,
                              description="seconds")]
Kind = Literal["Object", "Fixture", "Surface", "Manipulator"]
Shape = Literal["box", "cylinder", "sphere", "mesh", "plane", "gripper"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


class Pose(_Strict):
    position: Vec3 = Field(description="world position of the centre [m]")
    quat: Quat


class HandState(Pose):
    opening: Annotated[float, Field(allow_inf_nan=False, ge=0.0, le=MAX_OPENING,
                                    description="distance between the fingers [m]")]


class Frame(_Strict):
    t: Time
    objects: dict[Name, Pose] = Field(description="the pose of every Object entity")
    hand: HandState


class EntityInfo(_Strict):
    name: Name
    kind: Kind
    shape: Shape = "box"
    extents: Annotated[list[Extent], Field(min_length=3, max_length=3,
                       description="full size along the body's own axes [m]")]
    pose: Pose | None = Field(default=None, description="required for Fixture and Surface "
                                                        "entities, which do not move")


class PhaseNote(_Strict):
    """What the recorder knew: the program's phase that ran from `start` to `end`."""

    name: Name
    primitive: Name
    start: Time
    end: Time
    succeeded: bool


class Source(_Strict):
    """Where the track comes from (informational; the analysis does not read it)."""

    recorder: Text | None = None
    program: Text | None = None
    entry: Text | None = None
    scene: Text | None = None
    seed: Annotated[int, Field(ge=0)] | None = None
    outcome: Text | None = None
    description: Text | None = None


class Track(_Strict):
    format: Literal["rapidc-track/1"]
    source: Source | None = None
    hand: Name = Field(description="the name of the manipulator whose pose `hand` holds")
    entities: Annotated[list[EntityInfo], Field(min_length=1, max_length=MAX_ENTITIES)]
    frames: Annotated[list[Frame], Field(min_length=1, max_length=MAX_FRAMES)]
    phases: list[PhaseNote] = Field(default_factory=list)

    def objects(self) -> list[EntityInfo]:
        return [e for e in self.entities if e.kind == "Object"]


def generated_schema() -> dict[str, Any]:
    """The JSON Schema of the models (what track.schema.json holds)."""
    generated = {k: v for k, v in Track.model_json_schema().items() if k != "title"}
    return {"$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": "rapidc track",
            "description": "An execution or demonstration: entities, then per frame the time, "
                           "every Object's pose and the hand's pose and opening (SI units). "
                           "Also required, beyond the schema: unique entity names, a pose for "
                           "every Fixture and Surface, frames holding exactly the Objects' "
                           "poses, strictly increasing times, unit quaternions (docs/demos.md).",
            **generated}


def schema() -> dict[str, Any]:
    """The shipped JSON Schema (runtime/demonstrations/track.schema.json)."""
    data: dict[str, Any] = json.loads(SCHEMA.read_text(encoding="utf-8"))
    return data


# --- problems ----------------------------------------------------------------------------------

class TrackError(JsonError):
    """A track that cannot be read or is not valid; `problems` says where and why, each line
    `file:line:col: error: $.path: message`."""

    def __init__(self, problems: Sequence[JsonProblem], more: int = 0) -> None:
        super().__init__(problems, more)
        lines = [p.labelled() for p in self.problems]
        if more:
            lines.append(f"... and {more} more problems")
        self.args = ("\n".join(lines),)


# --- reading -----------------------------------------------------------------------------------

def load_track(path: str | os.PathLike[str]) -> Track:
    """Read and validate a track file (a regular file of at most 10 MiB). Raises TrackError."""
    name = str(path)
    try:
        text = read_text(path)
    except FileProblem as problem:
        raise TrackError([JsonProblem(name, "", f"cannot read the track: {problem}")]) \
            from None
    return parse_track(text, name)


def parse_track(text: str, file: str = "<track>") -> Track:
    """Validate track JSON text; problems carry their line and column in `text`."""
    try:
        data = loads(text, file)
    except JsonError as error:
        raise TrackError(error.problems) from None
    try:
        return validate_track(data, file)
    except TrackError as error:
        places = locate(text, [p.loc for p in error.problems])
        located = [replace(p, line=places[p.loc][0], column=places[p.loc][1])
                   for p in error.problems]
        raise TrackError(located, error.more) from None


def validate_track(data: Any, file: str = "<track>") -> Track:
    """Validate parsed JSON (`json.loads` output or an equal dict). Raises TrackError."""
    if not isinstance(data, Mapping):
        raise TrackError([JsonProblem(file, "$", "a track is a JSON object with `format`, "
                                                  "`hand`, `entities` and `frames`")])
    try:
        track = Track.model_validate(data)
    except ValidationError as error:
        found = [problem_of(tuple(e["loc"]), e["type"], e["msg"]) for e in error.errors()]
        raise _error(file, found) from None
    problems = list(_consistency(track))
    if problems:
        raise _error(file, problems)
    return track


def _consistency(track: Track) -> Iterable[tuple[Loc, str]]:
    """The rules beyond the schema."""
    seen: set[str] = set()
    for i, entity in enumerate(track.entities):
        if entity.name in seen:
            yield ("entities", i, "name"), f"duplicate entity name `{entity.name}`"
        seen.add(entity.name)
        if entity.kind in ("Fixture", "Surface") and entity.pose is None:
            yield ("entities", i), f"a {entity.kind} needs its `pose` (it does not move)"
        if entity.name == track.hand and entity.kind != "Manipulator":
            yield ("entities", i, "kind"), (f"`{entity.name}` is the track's hand, so its kind "
                                            "must be Manipulator")
    names = {e.name for e in track.objects()}
    if not names:
        yield ("entities",), "a track needs at least one entity of kind Object"
    # a pose missing from every frame is one problem, said once with the count of frames
    poses: dict[tuple[Loc, str], list[Any]] = {}
    for i, frame in enumerate(track.frames):
        for missing in sorted(names - frame.objects.keys()):
            poses.setdefault(((), f"the pose of `{missing}` is missing"),
                             [("frames", i, "objects"), 0])[1] += 1
        for extra in sorted(frame.objects.keys() - names):
            poses.setdefault(((extra,), "not an Object entity of the track"),
                             [("frames", i, "objects", extra), 0])[1] += 1
    for (_, message), (loc, count) in poses.items():
        yield loc, message + (f" (and in {count - 1} more frames)" if count > 1 else "")
    for i, frame in enumerate(track.frames):
        if i and frame.t <= track.frames[i - 1].t:
            yield ("frames", i, "t"), (f"{frame.t:g} s is not after the previous frame's "
                                       f"{track.frames[i - 1].t:g} s")
    for i, phase in enumerate(track.phases):
        if phase.end < phase.start:
            yield ("phases", i, "end"), f"{phase.end:g} s is before the start {phase.start:g} s"


def _error(file: str, found: Sequence[tuple[Loc, str]]) -> TrackError:
    error = problems(file, found)
    return TrackError(error.problems, error.more)


# --- writing -----------------------------------------------------------------------------------

def dump_track(track: Mapping[str, Any]) -> str:
    """The track as JSON text, one entity, phase or frame per line (small and diffable)."""
    def compact(value: Any) -> str:
        return json.dumps(value, separators=(", ", ": "), allow_nan=False)

    fields = []
    for key, value in track.items():
        if isinstance(value, list) and value:
            items = ",\n".join(f"    {compact(item)}" for item in value)
            fields.append(f"  {json.dumps(key)}: [\n{items}\n  ]")
        else:
            fields.append(f"  {json.dumps(key)}: {compact(value)}")
    return "{\n" + ",\n".join(fields) + "\n}\n"
