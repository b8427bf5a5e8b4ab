"""Reading an RGB-D frame's files (formats in runtime/reconstruction/rgbd.py and
docs/reconstruction.md).

Every input is untrusted: read with rapid_dsl/language/files.py (regular files, at most
10 MiB), images decoded only after their size is checked, JSON without duplicate keys, NaN or
Infinity, and every problem an RgbdError located as `file:line:column: error: ...` (JSON) or `file:
error: ...` (images), quoting no file content.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
import warnings
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rapid_dsl.language.files import FileProblem, decode_text, inside, read_bytes
from rapid_dsl.language.safe_json import JsonError, loads
from rapid_dsl.language.safe_yaml import excerpt
from rapid_dsl.runtime.reconstruction.rgbd import (
    DEFAULT_EXTRINSICS,
    INTRINSIC_FIELDS,
    MM,
    Frame,
    Intrinsics,
    ObjectInfo,
    RgbdError,
    problem,
)

MAX_SIDE = 8192                    # pixels per image side
MAX_PIXELS = 3840 * 2160           # pixels per image (4K; 63 masks of it are 0.5 GB)
MIN_FOV, MAX_FOV = 0.5, 170.0     # deg, a pinhole camera's field of view along each axis
MAX_ASPECT = 4.0                   # fx / fy and fy / fx: how far from square a pixel may be
MAX_MASKS = 63                     # a scene holds 64 objects, one of them the support
RGB_SUFFIXES = (".png", ".jpg", ".jpeg")
DEPTH_SUFFIXES = (".png", ".npy")
LABEL_FIELDS = ("label", "kind", "mass", "friction")


def read_frame(rgb: str | os.PathLike[str], depth: str | os.PathLike[str],
               intrinsics: str | os.PathLike[str], masks: str | os.PathLike[str], *,
               labels: str | os.PathLike[str] | None = None,
               extrinsics: str | os.PathLike[str] | None = None,
               surfaces: Iterable[str] = ()) -> Frame:
    """Read and check one frame's files; raises RgbdError naming the file and what is wrong.

    Every image must have the intrinsics' width and height. `surfaces` are names the masks may
    not take, which labels.json may describe as surfaces (the support's name).
    """
    k = read_intrinsics(intrinsics)
    image = read_rgb(rgb)
    depth_image = read_depth(depth)
    for path, array in ((rgb, image), (depth, depth_image)):
        _same_size(path, array.shape[:2], k, intrinsics)
    pose = read_extrinsics(extrinsics) if extrinsics is not None else DEFAULT_EXTRINSICS.copy()
    mask_files = list_masks(masks)
    surfaces = set(surfaces)
    found: dict[str, np.ndarray] = {}
    files = {"rgb": os.fspath(rgb), "depth": os.fspath(depth),
             "intrinsics": os.fspath(intrinsics)}
    for name, path in mask_files.items():
        if name in surfaces:
            raise problem(path, f"the name `{name}` is the support surface's; rename the mask")
        _check_name(path, name)
        mask = read_mask(path)
        _same_size(path, mask.shape, k, intrinsics)
        if not mask.any():
            raise problem(path, "the mask is empty (no pixel is set)")
        found[name] = mask
        files[f"mask:{name}"] = os.fspath(path)
    info = read_labels(labels, set(found), surfaces) if labels is not None else {}
    if labels is not None:
        files["labels"] = os.fspath(labels)
    if extrinsics is not None:
        files["extrinsics"] = os.fspath(extrinsics)
    return Frame(image, depth_image, k, pose, found, info, files)


def _check_name(path: Path, name: str) -> None:
    """A mask's file stem names its object: the scene schema must accept it."""
    from pydantic import ValidationError

    from rapid_dsl.runtime.scenes.schema import SceneObject

    try:
        SceneObject.model_validate({"name": name, "kind": "fixture", "shape": "box",
                                    "size": [0.1] * 3, "pose": {"position": [0, 0, 0]}})
    except ValidationError as error:
        message = error.errors()[0]["msg"].removeprefix("Value error, ")
        raise problem(path, f"`{excerpt(name)}` cannot name an object ({excerpt(message, 120)}"
                            "); a mask is <name>.png, the name letters, digits and _, not "
                            "starting with a digit") from None


def _same_size(path: str | os.PathLike[str], shape: tuple[int, ...], k: Intrinsics,
               intrinsics: str | os.PathLike[str]) -> None:
    height, width = shape[:2]
    if (width, height) != (k.width, k.height):
        raise problem(path, f"the image is {width}x{height} pixels, but "
                            f"{excerpt(os.fspath(intrinsics), 200)} says {k.width}x{k.height}")


def list_masks(folder: str | os.PathLike[str]) -> dict[str, Path]:
    """The folder's mask PNGs by object name (their file stems), sorted; each must lie inside
    the folder once symlinks are resolved."""
    folder = Path(folder)
    if not folder.is_dir():
        raise problem(folder, "no such folder" if not folder.exists() else
                      "not a folder (--masks names a folder of one PNG per object)")
    try:
        names = sorted(entry.name for entry in os.scandir(folder))
    except OSError as error:
        raise problem(folder, f"cannot list the folder: {error.strerror or error}") from None
    found: dict[str, Path] = {}
    for name in names:
        path = folder / name
        if name.startswith(".") or not name.lower().endswith(".png"):
            continue   # notes, hidden files: only PNGs are masks
        if not inside(path, [folder]):
            raise problem(path, f"a symbolic link to a file outside {excerpt(str(folder), 200)}")
        stem = name[: -len(".png")]
        if stem in found:
            raise problem(path, f"a second mask for `{excerpt(stem)}`")
        found[stem] = path
    if not found:
        raise problem(folder, "no mask: the folder holds no .png file")
    if len(found) > MAX_MASKS:
        raise problem(folder, f"{len(found)} masks; a scene holds at most {MAX_MASKS} objects "
                              "besides the support")
    return found


def _read(path: str | os.PathLike[str]) -> bytes:
    try:
        return read_bytes(path)
    except FileProblem as error:
        raise problem(path, f"cannot read: {error}") from None


def _image(path: str | os.PathLike[str], formats: tuple[str, ...]) -> Any:
    """A decoded PIL image of one of `formats`, its size checked before its pixels are read."""
    from PIL import Image

    data = _read(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")   # our own pixel limit is below PIL's bomb warning
            image = Image.open(io.BytesIO(data), formats=list(formats))
            width, height = image.size
            if width > MAX_SIDE or height > MAX_SIDE or width * height > MAX_PIXELS:
                raise problem(path, f"the image is {width}x{height} pixels; at most {MAX_SIDE} "
                                    f"per side and {MAX_PIXELS:,} in all")
            image.load()
    except RgbdError:
        raise
    except Image.DecompressionBombError:   # PIL's own limit, far above ours, checked on open
        raise problem(path, f"the image has more than {MAX_PIXELS:,} pixels") from None
    except Exception:  # PIL raises many kinds for malformed files
        raise problem(path, f"not a readable {' or '.join(formats)} image") from None
    return image


def read_rgb(path: str | os.PathLike[str]) -> np.ndarray:
    """(H, W, 3) uint8 from a PNG or JPEG (grey and alpha images are converted)."""
    if Path(path).suffix.lower() not in RGB_SUFFIXES:
        raise problem(path, "the RGB image is a .png, .jpg or .jpeg file")
    image = _image(path, ("PNG", "JPEG"))
    if image.mode not in ("RGB", "RGBA", "L", "LA", "P", "1"):
        raise problem(path, f"an RGB image has 8 bits per channel, this one is mode {image.mode}")
    return np.asarray(image.convert("RGB"), dtype=np.uint8)


def read_depth(path: str | os.PathLike[str]) -> np.ndarray:
    """(H, W) float32 metres, NaN where nothing was measured, from a 16-bit PNG (mm) or .npy
    (m)."""
    suffix = Path(path).suffix.lower()
    if suffix not in DEPTH_SUFFIXES:
        raise problem(path, "depth is a 16-bit PNG in millimetres or a .npy of metres")
    if suffix == ".npy":
        return _depth_npy(path)
    image = _image(path, ("PNG",))
    if image.mode not in ("I;16", "I;16B", "I;16L", "I"):
        bits = "8-bit" if image.mode in ("L", "P", "1") else f"mode {image.mode}"
        raise problem(path, f"a depth PNG is 16-bit single-channel in millimetres, this one is "
                            f"{bits}")
    raw = np.asarray(image).astype(np.float64)
    if raw.ndim != 2:
        raise problem(path, "a depth PNG has one channel")
    depth = np.where(raw > 0, raw * MM, np.nan)
    return depth.astype(np.float32)


def _depth_npy(path: str | os.PathLike[str]) -> np.ndarray:
    data = _read(path)
    try:
        array = np.load(io.BytesIO(data), allow_pickle=False)
    except Exception:  # numpy raises ValueError, EOFError, ... for malformed files
        raise problem(path, "not a readable .npy array (object arrays are refused)") from None
    if not isinstance(array, np.ndarray):
        raise problem(path, "a depth .npy holds one array")
    if array.ndim == 3 and array.shape[2] == 1:
        array = array[:, :, 0]
    if array.ndim != 2 or array.dtype.kind != "f":
        raise problem(path, f"a depth .npy is a 2-D float array of metres, this one is "
                            f"{array.dtype} with shape {list(array.shape)}")
    if array.shape[0] * array.shape[1] > MAX_PIXELS:
        raise problem(path, f"the image has more than {MAX_PIXELS:,} pixels")
    depth = np.asarray(array, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        depth = np.where(np.isfinite(depth) & (depth > 0), depth, np.nan)
    return depth.astype(np.float32)


def read_mask(path: str | os.PathLike[str]) -> np.ndarray:
    """(H, W) bool: the pixels that are not zero (in any colour channel; alpha is ignored)."""
    image = _image(path, ("PNG",))
    if image.mode == "P":
        image = image.convert("RGB")
    array = np.asarray(image)
    if array.ndim == 3:
        array = array[:, :, : 3 if array.shape[2] >= 3 else 1]
        return np.asarray(array.any(axis=2))
    return np.asarray(array != 0)


# --- JSON ------------------------------------------------------------------------------------

def _json(path: str | os.PathLike[str]) -> tuple[Any, str]:
    """The JSON value of a file and its text, read by the strict reader
    (rapid_dsl/language/safe_json.py: no duplicate keys, only finite numbers, bounded nesting)."""
    try:
        text = decode_text(_read(path))
    except FileProblem as error:
        raise problem(path, f"cannot read: {error}") from None
    try:
        return loads(text, os.fspath(path)), text
    except JsonError as error:
        first = error.problems[0]
        raise problem(path, (f"{first.path}: " if first.path else "") + first.message,
                      line=first.line, column=first.column) from None


def _position(text: str, offset: int) -> tuple[int, int]:
    if offset < 0:
        return 1, 1
    line = text.count("\n", 0, offset) + 1
    return line, offset - (text.rfind("\n", 0, offset) + 1) + 1


def _locate(text: str, keys: Sequence[str], *, at_key: bool = False,
            second: bool = False) -> tuple[int, int]:
    """Line and column of the value of a nested key (keys searched in order), or of the last key
    itself (`at_key`; `second`: its second occurrence, for a duplicate). Falls back to the last
    key found, else 1:1."""
    offset, found = 0, -1
    for depth, key in enumerate(keys):
        pattern = re.compile(re.escape(json.dumps(key)) + r"\s*:\s*")
        match = pattern.search(text, offset)
        if match and second and depth == len(keys) - 1:
            match = pattern.search(text, match.end()) or match
        if match is None:
            break
        last = depth == len(keys) - 1
        found, offset = (match.start() if at_key and last else match.end()), match.end()
    return _position(text, found)


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def read_intrinsics(path: str | os.PathLike[str]) -> Intrinsics:
    """A pinhole camera within physical bounds: each axis's field of view from MIN_FOV to MAX_FOV
    degrees, pixels at most MAX_ASPECT times as wide (or wide as tall), the principal
    point within one image size of the image. A focal length of 1e-308 would pass a mere
    positivity check and make every back-projected point infinite."""
    value, text = _json(path)
    if not isinstance(value, dict):
        raise problem(path, "intrinsics are a JSON object with " + ", ".join(INTRINSIC_FIELDS),
                      line=1, column=1)
    for key in value:
        if key not in INTRINSIC_FIELDS:
            line, column = _locate(text, [key], at_key=True)
            raise problem(path, f"`{excerpt(key)}`: unknown field (the fields are "
                                f"{', '.join(INTRINSIC_FIELDS)})", line=line, column=column)
    numbers: dict[str, float] = {}
    for key in ("width", "height", "fx", "fy", "cx", "cy"):
        if key not in value:
            raise problem(path, f"`{key}` is missing", line=1, column=1)
        number = _number(value[key])
        line, column = _locate(text, [key])
        size = numbers.get("width" if key in ("fx", "cx") else "height", 1.0)
        if key in ("width", "height"):
            if number is None or number != int(number) or not 1 <= number <= MAX_SIDE:
                raise problem(path, f"`{key}` must be a whole number of pixels from 1 to "
                                    f"{MAX_SIDE}", line=line, column=column)
        elif key in ("fx", "fy"):
            low, high = (size / (2 * math.tan(math.radians(fov) / 2))
                         for fov in (MAX_FOV, MIN_FOV))
            if number is None or not low <= number <= high:
                axis = "horizontal" if key == "fx" else "vertical"
                raise problem(path, f"`{key}` must be a positive focal length in pixels giving a "
                                    f"{axis} field of view from {MIN_FOV:g} to {MAX_FOV:g} deg: "
                                    f"for {size:.0f} pixels, from {math.ceil(low * 10) / 10:g} to "
                                    f"{math.floor(high):,}",
                              line=line, column=column)
            if key == "fy" and not 1 / MAX_ASPECT <= numbers["fx"] / number <= MAX_ASPECT:
                raise problem(path, f"`fx` / `fy` is {numbers['fx'] / number:.3g}; pixels are "
                                    f"at most {MAX_ASPECT:g} times as tall or as tall as "
                                    "wide", line=line, column=column)
        elif number is None or not -size <= number <= 2 * size:
            raise problem(path, f"`{key}` must be a number of pixels within one image size of "
                                f"the image: from {-size:.0f} to {2 * size:.0f}", line=line,
                          column=column)
        numbers[key] = float(number)  # type: ignore[arg-type]
    return Intrinsics(numbers["fx"], numbers["fy"], numbers["cx"], numbers["cy"],
                      int(numbers["width"]), int(numbers["height"]))


def read_extrinsics(path: str | os.PathLike[str]) -> np.ndarray:
    """The 4x4 camera-to-world matrix, its rotation made exactly orthonormal."""
    value, text = _json(path)
    if not isinstance(value, dict) or set(value) != {"camera_to_world"}:
        line, column = (1, 1)
        if isinstance(value, dict) and set(value) - {"camera_to_world"}:
            line, column = _locate(text, [sorted(set(value) - {"camera_to_world"})[0]],
                                   at_key=True)
        raise problem(path, 'extrinsics are {"camera_to_world": [[4 numbers] x 4]}', line=line,
                      column=column)
    line, column = _locate(text, ["camera_to_world"])
    rows = value["camera_to_world"]
    matrix = None
    if isinstance(rows, list) and len(rows) == 4 and all(
            isinstance(row, list) and len(row) == 4 for row in rows):
        numbers = [_number(x) for row in rows for x in row]
        if all(n is not None for n in numbers):
            matrix = np.array(numbers, dtype=float).reshape(4, 4)
    if matrix is None:
        raise problem(path, "`camera_to_world` must be 4 rows of 4 finite numbers", line=line,
                      column=column)
    if not np.allclose(matrix[3], [0, 0, 0, 1], atol=1e-6):
        raise problem(path, "`camera_to_world`: the last row must be [0, 0, 0, 1]", line=line,
                      column=column)
    rotation = matrix[:3, :3]
    if not np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-3) \
            or np.linalg.det(rotation) <= 0:
        raise problem(path, "`camera_to_world`: the upper-left 3x3 block is not a rotation "
                            "(orthonormal, determinant +1)", line=line, column=column)
    if np.abs(matrix[:3, 3]).max() > 10.0:
        raise problem(path, "`camera_to_world`: the camera lies more than 10 m from the origin "
                            "(the scene's workspace is +-10 m)", line=line, column=column)
    u, _, vt = np.linalg.svd(rotation)
    matrix[:3, :3] = u @ vt
    return matrix


def read_labels(path: str | os.PathLike[str], names: set[str],
                surfaces: set[str] | None = None) -> dict[str, ObjectInfo]:
    """labels.json: per object name a label, or an object of label, kind, mass and friction.
    Every key must name a mask or one of `surfaces` (the support, which takes a label and a
    friction only); the values are checked by the scene schema, as in a scene file."""
    surfaces = surfaces or set()
    value, text = _json(path)
    if not isinstance(value, dict):
        raise problem(path, 'labels are a JSON object: {"name": "label", ...} or {"name": '
                            '{"label": ..., "kind": ..., "mass": ..., "friction": ...}}',
                      line=1, column=1)
    out: dict[str, ObjectInfo] = {}
    for name, entry in value.items():
        line, column = _locate(text, [name], at_key=True)
        if name not in names | surfaces:
            known = ", ".join(sorted(names | surfaces))
            raise problem(path, f"`{excerpt(name)}`: no mask has this name (the names are "
                                f"{excerpt(known, 200)})", line=line, column=column)
        fields = {"label": entry} if isinstance(entry, str) else entry
        if not isinstance(fields, dict):
            raise problem(path, f"`{excerpt(name)}`: a label (text) or an object with "
                                f"{', '.join(LABEL_FIELDS)}", line=line, column=column)
        for key in fields:
            if key not in LABEL_FIELDS:
                where = _locate(text, [name, key], at_key=True)
                raise problem(path, f"`{excerpt(name)}.{excerpt(key)}`: unknown field (the "
                                    f"fields are {', '.join(LABEL_FIELDS)})", line=where[0],
                              column=where[1])
        for key in ("kind", "mass"):   # a surface's kind is surface; it has no mass
            if name in surfaces and key in fields and not (key == "kind"
                                                           and fields[key] == "surface"):
                where = _locate(text, [name, key], at_key=True)
                raise problem(path, f"`{excerpt(name)}.{key}`: `{excerpt(name)}` is the support,"
                                    " a surface (it takes a label and a friction)",
                              line=where[0], column=where[1])
        checked = _check_label(path, text, name, fields, "surface" if name in surfaces
                               else "object")
        out[name] = ObjectInfo(checked.get("label"), checked.get("kind"), checked.get("mass"),
                               checked.get("friction"))
    return out


def _check_label(path: str | os.PathLike[str], text: str, name: str,
                 fields: Mapping[str, Any], kind: str) -> dict[str, Any]:
    """The fields as the scene schema reads them (units allowed: `300g`), on a stand-in box."""
    from pydantic import ValidationError

    from rapid_dsl.runtime.scenes.schema import SceneObject

    kind = fields.get("kind", kind)
    trial = {"name": "label_check", "kind": kind, "shape": "box", "size": [0.1] * 3,
             "pose": {"position": [0, 0, 0]}} | dict(fields)
    if kind == "object" and "mass" not in fields:
        trial["mass"] = 1.0
    try:
        obj = SceneObject.model_validate(trial)
    except ValidationError as error:
        item = error.errors()[0]
        key = next((str(p) for p in item["loc"] if str(p) in LABEL_FIELDS), None)
        line, column = _locate(text, [name] + ([key] if key else []))
        message = item["msg"].removeprefix("Value error, ")
        if item["type"] == "literal_error":
            message = "must be one of object, fixture, surface"
        raise problem(path, f"`{excerpt(name)}{'.' + key if key else ''}`: {message}",
                      line=line, column=column) from None
    return {key: getattr(obj, key) for key in fields}
