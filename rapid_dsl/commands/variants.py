"""`rapidc variants SCENE -n N [--seed S] [--ranges FILE] -o DIR`: write seeded scene variants.

Variant i is DIR/<stem>-<S>-<iiii>.yaml, a pure function of (scene, S, i, ranges): the same
command writes the same bytes. Mesh files the variants use are copied into DIR/meshes/ under names
made from their content, so DIR is self-contained. Every file is written atomically through
rapid_dsl/language/files.py's OutputFolder (never through a symlink below DIR, never over an input:
the scene, the ranges and their meshes), and every variant is loaded back as a scene before it is
written. Sampling lives in rapid_dsl.runtime.variants.sampler (docs/variants.md).
Exit status: 0 written, 2 bad input (scene, ranges, options) or an unwritable output.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rapid_dsl.commands.building import print_scene_problems
from rapid_dsl.commands.common import (
    add_input_options,
    fail_usage,
    path_argument,
    positive_int,
    seed_int,
)

PROGRESS_FROM = 50     # variants: fewer finish too fast to need progress lines


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "variants", help="write seeded variants of a scene as scene files",
        description="Sample N variants of SCENE (object pose, size, shape, mass, friction, "
                    "restitution, colour; optional distractors) within the ranges and write "
                    "them as DIR/<stem>-<seed>-<index>.yaml. Exit status: 0 written, 2 bad "
                    "input or unwritable output.",
        epilog="The ranges file format is in docs/variants.md.")
    parser.add_argument("scene", metavar="SCENE", help="scene YAML file")
    parser.add_argument("-n", "--count", type=positive_int, required=True, metavar="N",
                        help="how many variants (at most 10000)")
    parser.add_argument("--seed", type=seed_int, default=0, metavar="S",
                        help="seed (default 0); variant i of seed S is always the same")
    parser.add_argument("--ranges", metavar="FILE",
                        help="ranges YAML file (default: the sampler's default ranges)")
    parser.add_argument("-o", "--output", metavar="DIR", required=True, type=path_argument,
                        help="folder to write the variants into (made if missing)")
    add_input_options(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    from rapid_dsl.runtime.scenes.scene import SceneError, load_scene
    from rapid_dsl.runtime.variants.ranges import load_ranges
    from rapid_dsl.runtime.variants.sampler import (
        MAX_SEED,
        MAX_VARIANTS,
        VariantError,
        VariantSampler,
    )

    if args.count > MAX_VARIANTS:
        return fail_usage(f"-n {args.count}: at most {MAX_VARIANTS} variants per run")
    if args.seed > MAX_SEED:
        return fail_usage(f"--seed {args.seed}: at most {MAX_SEED}")
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        return fail_usage(f"-o {args.output}: a file, not a folder")
    try:
        scene = load_scene(args.scene, allowed_dirs=args.allowed_dirs)
        ranges = load_ranges(args.ranges, scene, allowed_dirs=args.allowed_dirs) \
            if args.ranges else None
    except SceneError as error:
        print_scene_problems(error)
        return 2
    try:
        sampler = VariantSampler(scene, ranges)
    except VariantError as error:
        return fail_usage(f"{args.scene}: {error}")
    inputs = [args.scene, *([args.ranges] if args.ranges else []), *_meshes(scene, ranges)]
    try:
        writer = _Writer(out, inputs)
    except _Unwritable as error:
        return fail_usage(str(error))
    stem = _stem(args.scene)
    progress = _Progress(args.count, quiet=args.quiet or args.count < PROGRESS_FROM)
    written: list[dict[str, Any]] = []
    started = time.perf_counter()
    failure = None
    try:
        for index in range(args.count):
            variant = sampler.sample(args.seed, index)
            target = writer.write(variant.scene, f"{stem}-{args.seed}-{index:04d}.yaml")
            written.append({"file": str(target)} | variant.describe())
            progress.step(index + 1)
    except VariantError as error:
        failure = f"{args.scene}: {error}"
    except _Unwritable as error:
        failure = str(error)
    finally:
        progress.close()   # before any message: the progress line may be open on a terminal
        writer.close()
    if failure:
        return fail_usage(failure)
    if args.format == "json":
        print(json.dumps({"scene": args.scene, "seed": args.seed, "variants": written},
                         indent=2))
    if not args.quiet:
        shapes = {obj.name: obj.shape for obj in scene.objects}
        print(_summary(args, written, shapes, len(writer.copies), time.perf_counter() - started),
              file=sys.stderr)
    return 0


def _stem(scene: str) -> str:
    name = Path(scene).name
    for suffix in (".yaml", ".yml"):
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)]
    return name


class _Unwritable(Exception):
    """An output cannot be written (the message names it and says why)."""


class _Writer:
    """Writes variant scenes into one folder, with copies of the meshes they use."""

    def __init__(self, out: Path, inputs: list[str]):
        from rapid_dsl.language.files import FileProblem, output_folder

        self.out = out
        try:
            self.folder = output_folder(out, inputs=inputs)
        except FileProblem as problem:
            raise _Unwritable(str(problem)) from None
        self.copies: dict[str, Path] = {}    # source mesh -> its copy in DIR/meshes

    def close(self) -> None:
        self.folder.close()

    def write(self, scene: Any, name: str) -> Path:
        """Write the variant as DIR/`name`; its path."""
        from rapid_dsl.language.files import FileProblem
        from rapid_dsl.runtime.scenes.scene import SceneError, parse_scene, to_yaml

        for obj in scene.objects:
            if obj.mesh is not None:
                scene = scene.with_object(obj.name, mesh=str(self._mesh(obj.mesh)))
        target = self.out / name
        text = to_yaml(scene, relative_to=self.out)
        try:
            parse_scene(text, str(target), base_dir=self.out)
        except SceneError as error:   # the sampler validates every variant: a bug if reached
            raise AssertionError(f"a variant does not load back: {error}") from None
        try:
            return self.folder.write(name, text)
        except FileProblem as problem:
            raise _Unwritable(f"cannot write {target}: {problem}") from None

    def _mesh(self, source: str) -> Path:
        """The copy of a mesh in DIR/meshes, named by its content (written once per run; a
        source that is already that copy, as in variants of a variant, is kept)."""
        from rapid_dsl.language.files import FileProblem, identities, read_bytes

        if source in self.copies:
            return self.copies[source]
        try:
            data = read_bytes(source)
        except FileProblem as problem:
            raise _Unwritable(f"cannot copy mesh {source}: {problem}") from None
        name = f"meshes/mesh-{hashlib.sha256(data).hexdigest()[:16]}{Path(source).suffix}"
        try:
            if self.folder.identity(name) not in identities([source]):
                self.folder.write(name, data)
        except FileProblem as problem:
            raise _Unwritable(f"cannot write {self.out / name}: {problem}") from None
        self.copies[source] = (self.out / name).resolve()
        return self.copies[source]


def _meshes(scene: Any, ranges: Any) -> list[str]:
    """The mesh files the scene and the ranges name: inputs no variant file may replace."""
    return [obj.mesh for obj in scene.objects if obj.mesh] + list(ranges.meshes if ranges else ())


def _summary(args: argparse.Namespace, written: list[dict[str, Any]], shapes: Mapping[str, str],
             meshes: int, seconds: float) -> str:
    changed = sum(change["shape"] != shapes[change["name"]]
                  for item in written for change in item["objects"])
    distractors = sum(len(item["distractors"]) for item in written)
    redrawn = sum(item["attempts"] - 1 for item in written)
    first, last = Path(written[0]["file"]).name, Path(written[-1]["file"]).name
    files = first if len(written) == 1 else f"{first} .. {last}"
    copied = f", {_plural(meshes, 'mesh')} copied" if meshes else ""
    return (f"wrote {_plural(len(written), 'variant')} of {args.scene} to {args.output} "
            f"({files}): {_plural(changed, 'shape change')}, "
            f"{_plural(distractors, 'distractor')}, {_plural(redrawn, 'rejected draw')}{copied} "
            f"in {seconds:.1f} s")


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}{'es' if word.endswith('sh') else 's'}"


class _Progress:
    """`variants: 120/1000` on stderr: rewritten in place on a terminal, else every 10 %."""

    def __init__(self, total: int, *, quiet: bool):
        self.total, self.quiet = total, quiet
        self.tty = bool(getattr(sys.stderr, "isatty", lambda: False)())
        self.shown = 0
        self.last = 0.0

    def step(self, done: int) -> None:
        if self.quiet:
            return
        if self.tty:
            now = time.monotonic()
            if now - self.last >= 0.1 or done == self.total:
                self.last = now
                print(f"\rvariants: {done}/{self.total}", end="", file=sys.stderr, flush=True)
                self.shown = done
        elif done * 10 // self.total > self.shown * 10 // self.total:
            print(f"variants: {done}/{self.total}", file=sys.stderr)
            self.shown = done

    def close(self) -> None:
        if not self.quiet and self.tty and self.shown:
            print(file=sys.stderr)
