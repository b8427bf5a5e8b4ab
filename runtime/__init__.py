"""The rapid_dsl runtime: scenes, robots, batched MuJoCo rollouts, builtins and the CEM executor.

Generated programs import only this package. Nothing here imports the compiler side.
Heavy modules (mujoco, numpy) are imported by the submodules that need them, never here.
"""
