"""`rapidc bench verify`: both pool sizes run the same variants and the numbers come out."""

from __future__ import annotations

import json
from pathlib import Path

import pytest


@pytest.mark.slow
def test_bench_verify_measures_one_and_two_jobs_on_the_same_variants(rapidc, tmp_path: Path):
    out = tmp_path / "bench.json"
    run = rapidc("bench", "verify", "--variants", 2, "--samples", 8, "--iterations", 1,
                 "--repeats", 2, "--json", out)
    assert run.code == 0, run.err
    result = json.loads(out.read_text())
    assert [r["jobs"] for r in result["runs"]] == [1, 2] and result["repeats"] == 2
    assert result["same_results"] is True
    for measured in result["runs"]:
        assert measured["variants_per_minute"] > 0 and 0 <= measured["success_rate"] <= 1
    assert result["speedup"] == pytest.approx(result["runs"][1]["variants_per_minute"]
                                              / result["runs"][0]["variants_per_minute"])
    assert "speed-up 2 jobs / 1 job:" in run.out and "best of 2" in run.out


def test_bench_verify_bounds_its_options(rapidc):
    run = rapidc("bench", "verify", "--variants", 1001)
    assert run.code == 2 and "must be at most 1000" in run.err
