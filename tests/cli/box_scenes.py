"""Scenes of many small boxes on a table, written on the fly for the binding and memory tests."""

from __future__ import annotations

from pathlib import Path


def boxes_scene(path: Path, count: int, *, touching: bool = False) -> Path:
    """`count` 3 cm boxes b0, b1, ... on a table, 10 cm apart in rows of 8 (no two within 1 mm;
    b1 against b0 if `touching`)."""
    lines = ["robot: floating_gripper", "floor_height: -0.75m",
             "gripper_start: {position: [0.30, 0.0, 0.10]}", "objects:",
             "  - {name: table, kind: surface, shape: box, size: [1.6m, 1.6m, 0.75m], "
             "pose: {position: [0.55, 0.0, -0.375]}}"]
    for i in range(count):
        x, y = 0.1 * (i % 8), -0.4 + 0.1 * (i // 8)
        if touching and i == 1:
            x = 0.03
        lines.append(f"  - {{name: b{i}, kind: object, shape: box, size: [3cm, 3cm, 3cm], "
                     f"pose: {{position: [{x:.2f}, {y:.2f}, 1.5cm]}}, mass: 0.1kg}}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
