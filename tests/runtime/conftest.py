"""Runtime tests render offscreen: pick the headless GL back end before any test imports mujoco."""

import os
import sys

if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

# Import it now, with that back end: an in-process rapidc command (other than a rendering run)
# would otherwise be first and import it with GL off for the whole session (runtime/gl.py).
import mujoco  # noqa: E402, F401
