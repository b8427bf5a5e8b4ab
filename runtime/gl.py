"""MuJoCo's OpenGL back end, which MuJoCo picks from MUJOCO_GL once, when it is first imported.

A run without video or key frames needs no GL: `prepare(rendering=False)` imports mujoco with GL
disabled, so a back end that is missing or misnamed (MUJOCO_GL=osmesa without libOSMesa) cannot
break it. `prepare(rendering=True)` imports mujoco with the user's back end and opens a tiny
context, so a renderer that cannot start is a RenderError before the optimization, not after it.
This module must not import mujoco at module level: that would pick the back end.
"""

from __future__ import annotations

import importlib
import os
import sys

# What each headless back end needs on Debian/Ubuntu (docs/running.md).
_PACKAGES = {"egl": "libegl1 libopengl0 libgl1-mesa-dri", "osmesa": "libosmesa6"}
_KNOWN = ("egl", "osmesa", "glfw", "glx", "")
_DISABLED = ("disable", "disabled", "off", "false", "0")


class RenderError(RuntimeError):
    """Offscreen rendering is not available or the output cannot be written."""


def prepare(*, rendering: bool) -> None:
    """Import mujoco with the GL a command needs; call before anything else imports mujoco.

    Raises RenderError when `rendering` and no offscreen context can be opened. In a process
    that has imported mujoco already, the back end it picked stays (MuJoCo cannot switch).
    """
    if "mujoco" not in sys.modules:
        if rendering:
            try:
                importlib.import_module("mujoco")
            except Exception as error:  # a broken back end fails with several exception types
                raise RenderError(unavailable(error)) from None
        else:
            _import_without_gl()
    if rendering:
        _probe()


def backend() -> str:
    """MUJOCO_GL as MuJoCo reads it (empty means its default, GLFW)."""
    return os.environ.get("MUJOCO_GL", "").strip().lower()


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


def _import_without_gl() -> None:
    saved = os.environ.get("MUJOCO_GL")
    os.environ["MUJOCO_GL"] = "disable"
    try:
        importlib.import_module("mujoco")
    finally:
        # Only the import reads it; child processes and later messages see the user's value.
        if saved is None:
            del os.environ["MUJOCO_GL"]
        else:
            os.environ["MUJOCO_GL"] = saved


def _probe() -> None:
    mujoco = sys.modules["mujoco"]
    context_class = getattr(mujoco, "GLContext", None)
    if context_class is None:
        if backend() in _DISABLED:
            raise RenderError(unavailable())
        raise RenderError("offscreen rendering is unavailable: this process imported mujoco "
                          "without GL (prepare(rendering=False)), and MuJoCo cannot switch; "
                          "render in a new process")
    check_display()
    try:
        context = context_class(1, 1)
        context.make_current()
        context.free()
    except Exception as error:  # GL back ends fail with several exception types
        raise RenderError(unavailable(error)) from None
