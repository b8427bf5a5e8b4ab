"""The benchmark's test scenes: seeded draws of each task's scene family, with distractors.

Test scene i of a task is `task.layout(draw)` for a `Draw` of the issue's distribution (`draw`),
plus 1 to 3 irrelevant distractors placed on the task's support by the variant sampler
(runtime/variants/sampler.py `VariantSampler.distract`: the same placement, interpenetration and
robot-clearance checks as `rapidc variants`). A draw whose layout is not a valid scene, makes
things interpenetrate that the demonstration does not, or leaves no room for its distractors is
drawn again: attempt k of scene i draws everything from `default_rng([seed, i, k])`.

TEST_SEED is the benchmark's seed: task Tn draws from TEST_SEED + n (`task_seed`). It is disjoint
from every seed used while writing strategies: `rapidc verify` on variants of the demonstration
scenes and the task tests' draws of this distribution use seeds below 1000 (docs/benchmark.md),
and the demonstration scenes are NOMINAL draws, not seeded ones.
"""

from __future__ import annotations

import functools
import math
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from rapid_dsl.bench.nonprehensile.spec import NOMINAL, Draw, Task
from rapid_dsl.language.files import OutputFolder
from rapid_dsl.runtime.scenes.scene import Scene, load_scene, parse_scene, to_yaml
from rapid_dsl.runtime.variants.check import inspect
from rapid_dsl.runtime.variants.ranges import DistractorRanges, Ranges
from rapid_dsl.runtime.variants.sampler import Distractor, Rejected, VariantError, VariantSampler

TEST_SEED = 9000
MAX_ATTEMPTS = 50
OFFSET = 0.05                       # m, x and y of the object's position, each way
YAW = math.radians(30)              # rad, each way
SCALE = (0.8, 1.2)                  # per extent
MASS = (0.5, 2.0)                   # factor, log-uniform
FRICTION = (0.4, 1.0)               # absolute
DISTRACTORS = Ranges(distractors=DistractorRanges(count=(1, 3)))


class SceneDrawError(Exception):
    """No test scene can be drawn (every attempt was rejected; the message says why)."""


@dataclass(frozen=True, slots=True)
class TestScene:
    """One test scene: its draw, its scene, its distractors, and the draws it took."""

    __test__ = False    # not a pytest class

    task: str
    index: int
    seed: int
    draw: Draw
    scene: Scene
    distractors: tuple[Distractor, ...]
    attempts: int

    def describe(self) -> dict[str, Any]:
        return {"draw": asdict(self.draw), "attempts": self.attempts,
                "distractors": [asdict(d) for d in self.distractors]}


def _round(value: float) -> float:
    return round(float(value), 9)   # as runtime/variants/sampler.py: the file holds exactly these


def draw(task: Task, rng: np.random.Generator) -> Draw:
    """A perturbation of the task's object: offset, yaw, scale per axis, shape, mass, friction and
    colour, each uniform in its range (mass log-uniform)."""
    offset = rng.uniform(-OFFSET, OFFSET, size=2)
    yaw = rng.uniform(-YAW, YAW)
    scale = rng.uniform(*SCALE, size=3)
    shape = task.shapes[int(rng.integers(len(task.shapes)))]
    mass = math.exp(rng.uniform(math.log(MASS[0]), math.log(MASS[1])))
    friction = rng.uniform(*FRICTION)
    rgb = rng.uniform(0.0, 1.0, size=3)
    return Draw(offset=(_round(offset[0]), _round(offset[1])), yaw=_round(yaw),
                scale=(_round(scale[0]), _round(scale[1]), _round(scale[2])), shape=shape,
                mass=_round(mass), friction=_round(friction),
                rgba=(_round(rgb[0]), _round(rgb[1]), _round(rgb[2]), 1.0))


def layout_scene(task: Task, which: Draw, robot: str | None = None) -> Scene:
    """The task's layout of a draw as a validated scene (`robot` replaces its robot).
    Raises pydantic's ValidationError for a layout that is not a valid scene."""
    document = dict(task.layout(which))
    if robot is not None:
        document["robot"] = robot
    return Scene.model_validate(document)


def demo_scene(task: Task, robot: str | None = None) -> Scene:
    """The demonstration scene: the layout of NOMINAL (what `<name>.yaml` must hold)."""
    return layout_scene(task, NOMINAL, robot)


def demo_differences(task: Task) -> list[str]:
    """Where the task's `<name>.yaml` differs from layout(NOMINAL) (numbers within 1e-9)."""
    written = load_scene(task.demo_path).model_dump()
    return _differences(written, demo_scene(task).model_dump(), "")


def _differences(a: Any, b: Any, where: str) -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        keys = sorted(set(a) | set(b))
        return [d for k in keys for d in _differences(a.get(k), b.get(k), f"{where}.{k}")]
    if isinstance(a, list | tuple) and isinstance(b, list | tuple) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in _differences(x, y, f"{where}[{i}]")]
    if isinstance(a, int | float) and isinstance(b, int | float) \
            and not isinstance(a, bool) and not isinstance(b, bool):
        return [] if abs(a - b) <= 1e-9 else [f"{where.lstrip('.')}: {a} in the file, {b}"]
    return [] if a == b else [f"{where.lstrip('.')}: {a!r} in the file, {b!r}"]


@functools.cache
def _demo_contacts(task: Task, robot: str | None) -> frozenset[tuple[str, str]]:
    """The pairs that interpenetrate in the demonstration (forgiven in its test scenes)."""
    return inspect(demo_scene(task, robot)).penetrating


def sample_test_scene(task: Task, seed: int, index: int, robot: str | None = None) -> TestScene:
    """Test scene `index` of `task` for `seed` (module doc). Raises SceneDrawError."""
    reasons: Counter[str] = Counter()
    base = _demo_contacts(task, robot)
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng([seed, index, attempt])
        which = draw(task, rng)
        try:
            laid = layout_scene(task, which, robot)
        except ValidationError as error:
            first = error.errors()[0]
            where = ".".join(str(p) for p in first["loc"])
            reasons[f"its layout is not a valid scene ({where}: {first['msg']})"] += 1
            continue
        try:
            new = sorted(inspect(laid).penetrating - base)
        except ValueError as error:
            reasons[f"its MuJoCo model cannot be built ({error})"] += 1
            continue
        if new:
            reasons[f"`{new[0][0]}` and `{new[0][1]}` would interpenetrate"] += 1
            continue
        try:
            scene, distractors = VariantSampler(laid, DISTRACTORS).distract(rng, on=task.support)
        except Rejected as rejected:
            reasons[str(rejected)] += 1
            continue
        except VariantError as error:
            raise SceneDrawError(f"{task.key} scene {index}: {error}") from None
        return TestScene(task.key, index, seed, which, scene, distractors, attempt + 1)
    reason, times = reasons.most_common(1)[0]
    raise SceneDrawError(f"{task.key} scene {index} of seed {seed}: every one of {MAX_ATTEMPTS} "
                         f"draws was rejected, most often ({times}x) because {reason}")


def test_scene(task: Task, seed: int, index: int, robot: str | None = None) -> dict[str, Any]:
    """Test scene `index` of `task` for `seed` as a scene document (SI numbers)."""
    return sample_test_scene(task, seed, index, robot).scene.model_dump(mode="json")


test_scene.__test__ = False   # type: ignore[attr-defined]   # not a pytest test


def scene_name(task: Task, index: int) -> str:
    return f"{task.key.lower()}-{index:03d}.yaml"


def write_scene(scene: Scene, folder: OutputFolder, name: str) -> Scene:
    """Write the scene file `name` in `folder` atomically (runtime/scenes/scene.py's dump) and
    return the scene read back from it: what a run uses, so `rapidc run --scene FILE` replays it
    exactly. Mesh files go to `meshes/` beside it, named by their content (as `rapidc variants`
    keeps its folder whole). Raises FileProblem."""
    import hashlib

    from rapid_dsl.language.files import identities, read_bytes

    here = folder.path.resolve()
    for obj in scene.objects:
        if obj.mesh is not None and not Path(obj.mesh).is_relative_to(here):
            data = read_bytes(obj.mesh)
            copy = f"meshes/mesh-{hashlib.sha256(data).hexdigest()[:16]}{Path(obj.mesh).suffix}"
            if folder.identity(copy) not in identities([obj.mesh]):
                folder.write(copy, data)
            scene = scene.with_object(obj.name, mesh=str(folder.path.resolve() / copy))
    text = to_yaml(scene, relative_to=folder.path)
    loaded = parse_scene(text, str(folder.path / name), base_dir=folder.path)
    folder.write(name, text)
    return loaded


def task_seed(task: Task) -> int:
    """The scene seed of a task: TEST_SEED plus its number (T3: 9003), so tasks draw apart."""
    digits = "".join(ch for ch in task.key if ch.isdigit())
    return TEST_SEED + (int(digits) if digits else 0)
