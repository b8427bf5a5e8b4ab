"""Robots behind one interface: the scene's `robot:` name -> a `Robot`."""

from __future__ import annotations

import numpy as np

from rapid_dsl.runtime.robots.base import HandPose, Robot

ROBOT_NAMES = ("floating_gripper", "franka")


def make_robot(name: str, base: np.ndarray) -> Robot:
    """A robot by its scene name, with its base at `base` (world, m)."""
    if name == "floating_gripper":
        from rapid_dsl.runtime.robots.floating import FloatingGripper

        return FloatingGripper(base)
    if name == "franka":
        from rapid_dsl.runtime.robots.franka import Franka

        return Franka(base)
    raise ValueError(f"unknown robot `{name}`; known: {', '.join(ROBOT_NAMES)}")


__all__ = ["HandPose", "ROBOT_NAMES", "Robot", "make_robot"]
