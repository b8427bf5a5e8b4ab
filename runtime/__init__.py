"""The rapid_dsl runtime: scenes, robots, batched MuJoCo rollouts, builtins and the CEM executor.

Generated programs import only this package. Nothing here imports the compiler side.
Heavy modules (mujoco, numpy) are imported by the submodules that need them, never here.
"""

import os as _os
import sys as _sys

# MuJoCo reads MUJOCO_GL once, when it is first imported; headless Linux renders offscreen with EGL.
# Set here because this package is imported before any of its modules imports mujoco.
if _sys.platform.startswith("linux") and not _os.environ.get("DISPLAY"):
    _os.environ.setdefault("MUJOCO_GL", "egl")
