"""`rapidc bench check`: the generated programs are clean and the numbers come out."""

from __future__ import annotations

import json

import pytest

from rapid_dsl.bench.check import (
    SHAPES,
    Numbers,
    Scaling,
    generate_program,
    generate_strategy_file,
    report,
)
from rapid_dsl.frontend.driver import check_text


def test_generated_programs_check_clean_and_have_the_requested_size():
    program = generate_program(2000)
    assert 2000 <= program.count("\n") < 2100
    assert check_text(program, "big.rapid").diagnostics == []
    strategy = generate_strategy_file(200)
    assert 180 <= strategy.count("\n") <= 220
    assert check_text(strategy, "strategy.rapid").diagnostics == []


@pytest.mark.slow
def test_bench_check_prints_numbers(rapidc):
    run = rapidc("bench", "check", "--lines", "100", "--runs", "1", "--terms", "1000",
                 "--format", "json")
    assert run.code == 0, run.err
    numbers = json.loads(run.out)
    assert numbers["errors"] == 0
    assert numbers["program_lines"] >= 100 and numbers["stdlib_files"] >= 1
    assert all(numbers[k] > 0 for k in ("program_ms", "strategy_ms", "startup_ms",
                                         "lines_per_second"))
    rows = [Scaling(**{k: v for k, v in row.items() if k != "ratio"})
            for row in numbers["scaling"]]
    assert [row.shape for row in rows] == list(SHAPES)
    assert all(row.terms == 1000 and row.ms > 0 and row.ms_4n > 0 for row in rows)
    text = report(Numbers(**{k: v for k, v in numbers.items() if k != "lines_per_second"}
                          | {"scaling": rows}))
    assert "lines/s" in text and "target < 50 ms" in text and "target < 100 ms" in text
    assert "n = 1,000" in text and "4n = 4,000" in text and "one run `- - - ... 1` (E0409)" in text
