"""MuJoCo's OpenGL back end, which MuJoCo picks from MUJOCO_GL once, when it is first imported.

Only `rapidc run --video/--keyframes` renders. Every rapidc command runs `without_gl()`: while it
runs MUJOCO_GL is `disable`, so whatever imports mujoco (compile, bind, variants, bench, run) gets
it without GL, and a back end that is missing or misnamed (MUJOCO_GL=osmesa without libOSMesa)
cannot break it. `start_rendering()` imports mujoco with the user's back end instead and opens a
tiny context, so a renderer that cannot start is a RenderError before the optimization, not after.
This module must not import mujoco at module level: that would pick the back end.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

# What each headless back end needs on Debian/Ubuntu (docs/running.md).
_PACKAGES = {"egl": "libegl1 libopengl0 libgl1-mesa-dri", "osmesa": "libosmesa6"}
_KNOWN = ("egl", "osmesa", "glfw", "glx", "")
_DISABLED = ("disable", "disabled", "off", "false", "0")


class RenderError(RuntimeError):
    """Offscreen rendering is not available or the output cannot be written."""


# The user's MUJOCO_GL values while commands run without_gl (a stack: main() may nest in tests).
_saved: list[str | None] = []


@contextmanager
def without_gl() -> Iterator[None]:
    """MUJOCO_GL=disable while the block runs, the user's value again afterwards (child processes
    of the block inherit `disable`; they render nothing either)."""
    _saved.append(os.environ.get("MUJOCO_GL"))
    os.environ["MUJOCO_GL"] = "disable"
    try:
        yield
    finally:
        _set(_saved.pop())


def start_rendering() -> None:
    """Import mujoco with the user's GL back end and open a context; call before anything else
    imports mujoco. Raises RenderError if no offscreen context can be opened. In a process that
    has imported mujoco already, the back end it picked stays (MuJoCo cannot switch)."""
    if "mujoco" not in sys.modules:
        current = os.environ.get("MUJOCO_GL")
        _set(_saved[-1] if _saved else current)
        try:
            importlib.import_module("mujoco")
        except Exception as error:  # a broken back end fails with several exception types
            raise RenderError(unavailable(error)) from None
        finally:
            _set(current)
    _probe()


def backend() -> str:
    """The user's MUJOCO_GL as MuJoCo reads it (empty means its default, GLFW)."""
    value = _saved[-1] if _saved else os.environ.get("MUJOCO_GL")
    return (value or "").strip().lower()


def unavailable(error: BaseException | None = None, *, why: str = "") -> str:
    """Why rendering cannot start, naming MUJOCO_GL and what to install or set."""
    name = backend()
    shown = f"MUJOCO_GL={name}" if name else "an empty MUJOCO_GL"
    if not why:
        if name in _DISABLED:
            why = "turns rendering off"
        elif name not in _KNOWN:
            why = "is not a GL back end MuJoCo knows"
        elif name in _PACKAGES:
            why = f"cannot start (it needs the system package(s) {_PACKAGES[name]})"
        else:
            why = "cannot start"
    detail = " ".join(f"{type(error).__name__}: {error}".split())[:200] if error else ""
    return (f"offscreen rendering is unavailable: {shown} {why}"
            + (f" [{detail}]" if detail else "")
            + ". For --video and --keyframes on a machine without a display set MUJOCO_GL=egl "
            f"(Debian/Ubuntu: apt-get install {_PACKAGES['egl']}) or MUJOCO_GL=osmesa (apt-get "
            f"install {_PACKAGES['osmesa']}); runs without them need no GL")


def check_display() -> None:
    """Refuse where GLFW would abort the process: no display and no headless back end."""
    mujoco = sys.modules["mujoco"]
    module = getattr(getattr(mujoco, "GLContext", None), "__module__", "")
    if module.endswith("glfw") and sys.platform.startswith("linux") \
            and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise RenderError(unavailable(why="selects GLFW, which needs a display, and DISPLAY "
                                          "is unset"))


def _set(value: str | None) -> None:
    if value is None:
        os.environ.pop("MUJOCO_GL", None)
    else:
        os.environ["MUJOCO_GL"] = value


def _probe() -> None:
    mujoco = sys.modules["mujoco"]
    context_class = getattr(mujoco, "GLContext", None)
    if context_class is None:
        if backend() in _DISABLED:
            raise RenderError(unavailable())
        raise RenderError("offscreen rendering is unavailable: this process imported mujoco "
                          "without GL (an earlier command ran without_gl), and MuJoCo cannot "
                          "switch; render in a new process")
    check_display()
    try:
        context = context_class(1, 1)
        context.make_current()
        context.free()
    except Exception as error:  # GL back ends fail with several exception types
        raise RenderError(unavailable(error)) from None
