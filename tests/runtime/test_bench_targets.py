"""`rapidc bench rollouts` and `rapidc bench primitives` run the real examples and report
consistent numbers (tiny budgets; no speed assertion)."""

from __future__ import annotations

import json

import pytest

from rapid_dsl.bench import primitives, rollouts
from rapid_dsl.cli import main


def test_cem_rate_is_its_steps_over_its_wall_time_against_the_same_run_limit():
    r = rollouts.measure_robot("floating_gripper", repeats=1, synthetic=False, samples=4,
                               iterations=1)
    run = r["runs"][0]
    assert r["cem_steps"] == run["steps"] > 0
    assert r["cem_steps_per_s"] == pytest.approx(run["steps"] / run["cem_seconds"])
    assert r["limit_steps_per_s"] == pytest.approx(r["raw_runs"][0] * r["cores"])
    assert r["ratio"] == pytest.approx(r["cem_steps_per_s"] / r["limit_steps_per_s"])
    assert r["ratio_to_stepped"] == pytest.approx(
        r["cem_steps_per_s"] / (r["stepped_raw_steps_per_s"] * r["cores"]))
    assert run["cem_seconds"] < run["run_seconds"]
    assert "MISSED" in rollouts.report([{**r, "ratio": 0.1}])


def test_unknown_robot_is_a_value_error():
    with pytest.raises(ValueError, match="unknown robot"):
        rollouts.measure_robot("ur5")


def test_primitives_rows_name_the_demo_phase_and_count_its_rollouts():
    rows = primitives.measure(primitives=["topple"], samples=4, iterations=1)
    assert [r["primitive"] for r in rows] == ["topple"]
    seed = rows[0]["seeds"][0]
    assert seed["rollouts"] == 4 and seed["steps"] > 0
    assert seed["steps_per_s"] == pytest.approx(seed["steps"] / seed["cem_seconds"])
    assert "topple_carton:tip" in primitives.report(rows, 1)


def test_every_stdlib_primitive_has_a_benchmark_demo():
    from rapid_dsl.bench.examples import ROOT

    stdlib = {p.stem for p in (ROOT / "stdlib_primitives").glob("*.rapid")}
    assert {d.primitive for d in primitives.DEMOS} == stdlib
    with pytest.raises(ValueError, match="unknown primitive"):
        primitives.measure(primitives=["juggle"])


@pytest.mark.slow
def test_bench_primitives_command_writes_json(tmp_path, capsys):
    out = tmp_path / "p.json"
    # the budget flags are not on the command line: run the cheapest demo at its default budget
    assert main(["bench", "primitives", "--primitive", "lift", "--primitive", "move",
                 "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert [r["primitive"] for r in rows] == ["lift", "move"]
    assert "pick_and_place:carry" in capsys.readouterr().out
