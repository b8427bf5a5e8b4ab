"""docs/scenes.md says what the code does: its example loads, its limits and reserved names are
the ones the scene schema and the model builders use."""

from __future__ import annotations

import math
import re
from pathlib import Path

from rapid_dsl.language import safe_yaml
from rapid_dsl.language.files import MAX_INPUT_BYTES
from rapid_dsl.runtime.scenes import meshes
from rapid_dsl.runtime.scenes import schema as scene_schema
from rapid_dsl.runtime.scenes.scene import parse_scene
from rapid_dsl.runtime.scenes.world import reserved_names

DOC = (Path(__file__).resolve().parents[2] / "docs" / "scenes.md").read_text()


def section(title: str) -> str:
    return DOC.split(f"## {title}\n", 1)[1].split("\n## ", 1)[0]


def test_the_example_scene_loads():
    example = re.search(r"```yaml\n(.*?)```", DOC, re.DOTALL)
    assert example is not None
    scene = parse_scene(example.group(1))
    assert [obj.name for obj in scene.objects] == ["table", "box"]


def test_the_limits_table_matches_the_code():
    rows = dict(re.findall(r"^\| (.+?) \| (.+) \|$", section("Limits"), re.MULTILINE))
    lo, hi = scene_schema.MASS_RANGE
    smallest, largest = scene_schema.SIZE_RANGE
    expected = {
        "scene file": f"at most {MAX_INPUT_BYTES >> 20} MiB",
        "YAML nesting": f"at most {safe_yaml.MAX_DEPTH} levels",
        "YAML tokens": f"at most {safe_yaml.MAX_TOKENS:,}",
        "YAML values": f"at most {safe_yaml.MAX_VALUES:,}",
        "integers": f"at most {safe_yaml.MAX_INT_DIGITS:,} digits",
        "objects": f"1 to {scene_schema.MAX_OBJECTS} per scene",
        "`mass`": f"{lo * 1000:g} g to {hi:g} kg",
        "`size`": f"every full extent {smallest * 1000:g} mm to {largest:g} m",
        "`friction`": "{:g} to {:g}".format(*scene_schema.FRICTION_RANGE),
        "`restitution`": "{:g} to {:g}".format(*scene_schema.RESTITUTION_RANGE),
        "positions": f"within ±{scene_schema.WORKSPACE:g} m",
        "angles": f"within ±{math.degrees(scene_schema.MAX_ANGLE):g}deg",
        "`name`": f"at most {scene_schema.MAX_NAME} characters",
        "`label`": f"at most {scene_schema.MAX_LABEL} characters",
        "`mesh`": f"at most {scene_schema.MAX_PATH} characters of plain text; .obj, .stl or .ply; "
                  f"inside the allowed folders; a scene's mesh files together at most "
                  f"{scene_schema.MAX_MESH_BYTES >> 20} MiB",
    }
    for row, text in expected.items():
        assert text in rows[row], (row, rows[row])
    meshes_text = " ".join(DOC.split("**Meshes.**", 1)[1].split("**Friction.**")[0].split())
    assert f"fills less than {meshes.MIN_FILL * 100:g} % of its bounding box" in meshes_text
    assert f"more than {meshes.MAX_VERTICES:,} vertices" in meshes_text
    assert f"more than {meshes.MAX_HULL_VERTICES:,} vertices" in meshes_text
    assert f"coordinates beyond 10^{round(math.log10(meshes.MAX_COORDINATE))}" in meshes_text


def test_the_reserved_names_listed_are_the_ones_the_builders_use():
    listed: set[str] = set()
    text = section("Reserved names")
    for stem, start, stop in re.findall(r"`([a-z_]+?)(\d)` \.\. `[a-z_]+?(\d)`", text):
        listed |= {f"{stem}{i}" for i in range(int(start), int(stop) + 1)}
    listed |= set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)`", text))
    assert listed == {name for name in reserved_names() if ":" not in name}
