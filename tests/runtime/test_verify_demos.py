"""Every stdlib primitive's demonstration verifies: `rapidc verify` on its demo scene and 8 seeded
variants succeeds in every run, with the demo budgets of tests/stdlib/test_demos.py and the mild
ranges there (pose, yaw, size, mass and friction of every object), two jobs at a time."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rapid_dsl.bench.primitives import DEMOS
from rapid_dsl.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
BUDGET = {"samples": 12, "iterations": 2}
BUDGETS = {"flip_box.rapid": {"samples": 24, "iterations": 3}}   # flip needs a few more rollouts
MILD = "position: 1.5cm\nyaw: 8deg\nsize: 0.08\nmass: 0.25\nfriction: 0.15\n"
PAIRS = sorted({(d.program, d.scene) for d in DEMOS})


def test_the_demos_cover_every_stdlib_primitive():
    stdlib = {p.stem for p in (ROOT / "stdlib_primitives").glob("*.rapid")}
    assert {d.primitive for d in DEMOS} == stdlib


@pytest.mark.slow
@pytest.mark.parametrize("program, scene", PAIRS, ids=[p for p, _ in PAIRS])
def test_the_demo_verifies_on_its_scene_and_8_variants(program: str, scene: str,
                                                       tmp_path: Path):
    ranges = tmp_path / "mild.yaml"
    ranges.write_text(MILD)
    budget = BUDGETS.get(program, BUDGET)
    report = tmp_path / "r.json"
    code = main(["verify", str(EXAMPLES / program), "--scene", str(EXAMPLES / "scenes" / scene),
                 "--variants", "8", "--seed", "11", "--ranges", str(ranges), "--jobs", "2",
                 "--samples", str(budget["samples"]), "--iterations", str(budget["iterations"]),
                 "--report", str(report), "--quiet"])
    data = json.loads(report.read_text())
    failures = [(r["variant"], r["failure"]) for r in data["results"]
                if r["outcome"] != "succeeded"]
    assert code == 0 and not failures, failures
    assert data["summary"]["runs"] == 9
