"""The rollout benchmark runs and reports consistent numbers (tiny budget; no speed assertion)."""

from __future__ import annotations

import pytest

from rapid_dsl.runtime.bench import bench_rollouts


def test_bench_reports_rates_and_ratios():
    result = bench_rollouts("floating_gripper", samples=4, nstep=100, repeats=1)
    assert result["raw_steps_per_s"] > 0 and result["rollout_steps_per_s"] > 0
    assert result["limit_steps_per_s"] == pytest.approx(result["raw_steps_per_s"] * result["cores"])
    assert result["ratio"] == pytest.approx(result["rollout_steps_per_s"]
                                            / result["limit_steps_per_s"])
    assert result["unstable"] == 0


def test_bench_rejects_unknown_robots():
    with pytest.raises(ValueError, match="unknown robot"):
        bench_rollouts("ur5")
