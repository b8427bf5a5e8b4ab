"""Property: a scene file either loads and builds a MuJoCo model for both robots, or is refused
with located, short scene errors; never any other exception.

Documents are built from valid scenes with fields replaced by hostile values: huge, tiny,
negative and non-finite numbers (also as unit strings), long or weird strings, deep nesting, wrong
types, reserved names, paths out of the folder, and unknown keys. Examples are derandomized so CI is
repeatable; set RAPIDC_HYPOTHESIS_RANDOM=1 to explore.
"""

from __future__ import annotations

import atexit
import copy
import io
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mesh_files import write_obj
from ruamel.yaml import YAML

from rapid_dsl.language.safe_yaml import read_yaml
from rapid_dsl.runtime.robots import ROBOT_NAMES
from rapid_dsl.runtime.scenes.scene import SceneError, parse_scene
from rapid_dsl.runtime.scenes.world import build_world, reserved_names

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
WORK = Path(tempfile.mkdtemp(prefix="rapid-scene-properties-"))
atexit.register(shutil.rmtree, WORK, ignore_errors=True)
write_obj(WORK / "mug.obj")
write_obj(WORK / "tiny.obj", extents=(0.001, 0.001, 0.001))
write_obj(WORK.parent / f"{WORK.name}-outside.obj")
atexit.register(os.unlink, WORK.parent / f"{WORK.name}-outside.obj")

SHAPES = {
    "objects": [
        {"name": "table", "kind": "surface", "shape": "box", "size": ["1.0m", "1.2m", "0.75m"],
         "pose": {"position": [0.55, 0.0, -0.375]}, "friction": 0.6},
        {"name": "can", "kind": "object", "shape": "cylinder", "size": ["6cm", "12cm"],
         "pose": {"position": [0.4, 0.2, 0.06], "yaw": "30deg"}, "mass": 0.2,
         "restitution": 0.3, "rgba": [0.1, 0.2, 0.3, 1.0], "label": "tin can"},
        {"name": "ball", "kind": "object", "shape": "sphere", "size": "4cm",
         "pose": {"position": [0.4, -0.2, 0.02]}, "mass": "50g"},
        {"name": "mug", "kind": "object", "shape": "mesh", "mesh": "mug.obj",
         "pose": {"position": [0.6, 0.0, 0.05], "pitch": 0.1, "roll": -0.1}, "mass": "0.3kg"},
    ],
    "robot": "franka", "robot_base": [0, 0, 0], "floor_height": "-0.75m",
    "gripper_start": {"position": [0.3, 0.0, 0.15], "yaw": "10deg", "pitch": 0.0},
}


def _plain(node: Any) -> Any:
    if isinstance(node, dict):
        return {str(k): _plain(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_plain(v) for v in node]
    return node


BASES = [_plain(read_yaml((EXAMPLES / name).read_text()))
         for name in ("flip_box.yaml", "push_box_franka.yaml")] + [SHAPES]

# --- hostile values -------------------------------------------------------------------------

NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10 ** 450), max_value=10 ** 450),
    st.sampled_from([0, -0.0, 5e-324, 1e-300, 1e-9, 0.004, 0.8, 0.81, 2.0, 2.01, 100.0, 100.01,
                     1e308, 10 ** 401, -1, 720.0, 12.57]),
)
UNITS = st.sampled_from(["", "m", "cm", "mm", "deg", "rad", "kg", "g", "s", "ms", "N", " m",
                         "furlong", "e", "kgm"])
UNIT_STRINGS = st.builds(lambda n, u: f"{n}{u}", NUMBERS.map(repr), UNITS)
WEIRD = st.sampled_from(["", " ", "x" * 5000, "../mug.obj", f"../{WORK.name}-outside.obj",
                         str(WORK / "mug.obj"), "/etc/passwd", "mug.OBJ", "tiny.obj", "a\x00b",
                         "\u202e", "\x1b[31m", "[[[[", "*a", "&a", "!!python/name:os.system",
                         "nan", ".inf", "1e400", "-0", "\ud7ff", "\n\n", "true", "~", "mug.dae",
                         "link0/../mug.obj"])
STRINGS = st.one_of(st.text(max_size=40), WEIRD, st.sampled_from(sorted(reserved_names())),
                    st.integers(0, 12_000).map(lambda n: "y" * n))
LEAVES = st.one_of(st.none(), st.booleans(), NUMBERS, UNIT_STRINGS, STRINGS)
NESTED = st.recursive(LEAVES, lambda inner: st.lists(inner, max_size=4)
                      | st.dictionaries(st.text(max_size=8), inner, max_size=3), max_leaves=12)
DEEP = st.integers(1, 40).map(lambda depth: _deep(depth))
# values at the bounds, alone or in lists: these mostly load, and must then build
EDGES = st.sampled_from([0, 1, 0.0, 0.001, "1g", "100kg", 100, "5mm", "2m", 0.005, 2.0, 10.0,
                         -10.0, "10m", "-10m", "720deg", "-720deg", 12.566, 0.8, 0.5, "0.5m"])
HOSTILE = st.one_of(LEAVES, NESTED, DEEP, st.lists(NUMBERS, min_size=1, max_size=5),
                    st.lists(UNIT_STRINGS, min_size=1, max_size=5), EDGES,
                    st.lists(EDGES, min_size=1, max_size=4))


def _deep(depth: int) -> Any:
    value: Any = 1
    for _ in range(depth):
        value = [value]
    return value


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every place in a document a value sits (and the document's own keys)."""
    found = [prefix] if prefix else []
    if isinstance(node, dict):
        for key, value in node.items():
            found += _paths(value, prefix + (key,))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            found += _paths(value, prefix + (index,))
    return found


@st.composite
def documents(draw: st.DrawFn, values: st.SearchStrategy[Any] = HOSTILE,
              numeric_only: bool = False) -> dict[str, Any]:
    """A base scene with 1-3 values replaced (or fields added), or with only numbers replaced."""
    doc = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(1, 4 if numeric_only else 3))):
        paths = [path for path in _paths(doc) if not numeric_only or _numeric(doc, path)]
        path = draw(st.sampled_from(paths))
        parent = doc
        for part in path[:-1]:
            parent = parent[part]
        if not numeric_only and isinstance(parent, dict) and draw(st.integers(0, 3)) == 0:
            key = draw(st.sampled_from(["label", "restitution", "rgba", "mesh", "size", "mass",
                                        "pitch", "roll", "yaw", "source", "extra"]))
            parent[key] = draw(values)     # a field that may be absent, or an unknown one
        else:
            parent[path[-1]] = draw(values)
    return doc


def _numeric(doc: Any, path: tuple[Any, ...]) -> bool:
    """Whether the value at `path` is a number or a quantity such as `3cm`."""
    for part in path:
        doc = doc[part]
    if isinstance(doc, bool):
        return False
    return isinstance(doc, (int, float)) or isinstance(doc, str) and doc[:1] in set("0123456789-.")


def _yaml(doc: Any) -> str:
    stream = io.StringIO()
    yaml = YAML(typ="safe", pure=True)
    yaml.dump(doc, stream)
    return stream.getvalue()


def _settings(examples: int) -> settings:
    return settings(max_examples=examples, deadline=None, database=None,
                    derandomize=not os.environ.get("RAPIDC_HYPOTHESIS_RANDOM"),
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def loads_and_builds_or_is_refused(doc: dict[str, Any]) -> None:
    """The property, for the document's robot or, when that is valid, for both robots."""
    robots = ROBOT_NAMES if doc.get("robot") in ROBOT_NAMES else (doc.get("robot"),)
    for robot in robots:
        text = _yaml(doc | {"robot": robot})
        try:
            scene = parse_scene(text, "scene.yaml", base_dir=WORK)
        except SceneError as error:
            assert error.problems
            for problem in error.problems:
                shown = str(problem)
                assert problem.file == "scene.yaml" and problem.line >= 1 and problem.column >= 1
                assert problem.line <= text.count("\n") + 1
                assert problem.message and len(shown) < 400 and shown.isprintable(), shown
            continue
        world = build_world(scene)
        assert world.model.nbody >= len(scene.objects) + 1


@pytest.mark.slow
@_settings(100)
@given(documents())
def test_hostile_fields_load_and_build_for_both_robots_or_are_located_scene_errors(doc):
    loads_and_builds_or_is_refused(doc)


@pytest.mark.slow
@_settings(80)
@given(documents(st.one_of(EDGES, NUMBERS, UNIT_STRINGS), numeric_only=True))
def test_numbers_at_and_beyond_the_bounds_build_or_are_refused(doc):
    loads_and_builds_or_is_refused(doc)
