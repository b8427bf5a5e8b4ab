"""Runtime tests render offscreen: pick the headless GL back end before any test imports mujoco."""

import os
import sys

if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")
