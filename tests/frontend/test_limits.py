"""Budget maxima (language/limits.py): the checker refuses a program above one, at the value, and
`rapidc run` refuses an option above one as a usage error; docs/language.md states the same
numbers. Programs at the maxima check clean.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import time
from pathlib import Path

import pytest

from rapid_dsl.cli import main
from rapid_dsl.language import limits

from .test_checker import check, prim

ROOT = Path(__file__).resolve().parents[2]


def rapidc(*argv: object) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def optimize(settings: str) -> str:
    return prim(extra=f"  optimize {{ {settings} }}")


def keypoints(n: int) -> str:
    return prim(motion="\n" + "".join(f"    keypoint k{i} = pos(target) + {i}cm * up\n"
                                      for i in range(n)) + "  ")


@pytest.mark.parametrize("text", [
    optimize(f"samples {limits.MAX_SAMPLES}; elites {limits.MAX_ELITES}; "
             f"iterations {limits.MAX_ITERATIONS}; seed {limits.MAX_SEED}"),
    prim(motion=f"keypoint reach = pos(target); duration {limits.MAX_DURATION:g}s"),
    prim(motion="keypoint reach = pos(target); duration 10000ms"),
    keypoints(limits.MAX_KEYPOINTS),
])
def test_budgets_at_their_maxima_check_clean(text: str) -> None:
    result = check(text)
    assert result.diagnostics == [], [d.message for d in result.diagnostics]


@pytest.mark.parametrize(("setting", "code", "message"), [
    ("samples 100000000", "E0410", "`samples` 100000000 is above the maximum of 1024"),
    ("samples 1025", "E0410", "`samples` 1025 is above the maximum of 1024"),
    ("samples 1e300", "E0410", "`samples` 1e+300 is above the maximum of 1024"),
    ("iterations 100000000", "E0410", "`iterations` 100000000 is above the maximum of 100"),
    ("samples 1024; elites 2000", "E0410", "`elites` 2000 is above the maximum of 1024"),
    ("seed 2147483648", "E0406", "`seed` must be a non-negative integer"),
])
def test_optimize_budgets_above_their_maxima(setting: str, code: str, message: str) -> None:
    text = optimize(setting)
    [d] = check(text).diagnostics
    assert (d.code, d.message) == (code, message)
    value = setting.split("; ")[-1].split(" ")[1]
    assert text.splitlines()[d.span.line - 1][d.span.col - 1:d.span.end_col - 1] == value
    if code == "E0410":
        assert d.help is not None and "docs/language.md, Limits" in d.help


def test_a_duration_above_the_maximum() -> None:
    text = prim(motion="keypoint reach = pos(target); duration 1000000s")
    [d] = check(text).diagnostics
    assert d.code == "E0411"
    assert d.message == "`duration` 1000000s is above the maximum of 10s"
    assert text.splitlines()[d.span.line - 1][d.span.col - 1:d.span.end_col - 1] == "1000000s"
    [d] = check(prim(motion="keypoint reach = pos(target); duration 10.001s")).diagnostics
    assert d.code == "E0411"


def test_more_keypoints_than_the_maximum_is_one_error_at_the_first_one_too_many() -> None:
    text = keypoints(limits.MAX_KEYPOINTS + 3)
    [d] = check(text).diagnostics
    assert d.code == "E0412"
    assert d.message == "`motion` declares 19 keypoints, more than the maximum of 16"
    line = text.splitlines()[d.span.line - 1]
    assert line[d.span.col - 1:d.span.end_col - 1] == "keypoint k16"


def test_huge_budgets_are_reported_at_once(tmp_path: Path) -> None:
    """The findings: these budgets passed the checker and then exhausted memory or hung."""
    path = tmp_path / "greedy.rapid"
    path.write_text(optimize("samples 100000000; iterations 100000000").replace(
        "keypoint reach = pos(target)", "keypoint reach = pos(target); duration 1000000s"),
        encoding="utf-8")
    started = time.perf_counter()
    code, out, _ = rapidc("check", path)
    assert time.perf_counter() - started < 5
    assert code == 1
    assert re.findall(r"error\[(E\d+)\]", out) == ["E0410", "E0410", "E0411"]


@pytest.mark.parametrize(("option", "maximum"), [("--samples", limits.MAX_SAMPLES),
                                                  ("--iterations", limits.MAX_ITERATIONS)])
def test_run_options_above_the_maxima_are_usage_errors(tmp_path: Path, option: str,
                                                       maximum: int) -> None:
    program, scene = tmp_path / "none.rapid", tmp_path / "none.yaml"
    code, _, err = rapidc("run", program, "--scene", scene, option, maximum + 1)
    assert code == 2
    assert f"argument {option}: must be at most {maximum}" in err
    code, _, err = rapidc("run", program, "--scene", scene, option, 100000000)
    assert code == 2 and "must be at most" in err
    # at the maximum the option is accepted: what fails is the missing program
    code, _, err = rapidc("run", program, "--scene", scene, option, maximum)
    assert code == 2 and option not in err and "none.rapid" in err


def test_the_language_reference_states_the_maxima_of_runtime_limits() -> None:
    text = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    section = text[text.index("### Limits"):text.index("## 10.")]
    rows = dict(re.findall(r"^\| (.+?) \| (\S+).*\|", section, re.MULTILINE))
    assert rows["`optimize samples`"] == str(limits.MAX_SAMPLES)
    assert rows["`optimize elites`"] == str(limits.MAX_ELITES)
    assert rows["`optimize iterations`"] == str(limits.MAX_ITERATIONS)
    assert rows["`optimize seed`"] == str(limits.MAX_SEED)
    assert rows["`motion duration`"] == f"{limits.MAX_DURATION:g}s"
    assert rows["keypoints of one `motion`"] == str(limits.MAX_KEYPOINTS)
    assert rows["`motion spread`"] == f"{limits.MAX_SPREAD * 100:g}cm"
    assert rows["`motion spread_angle`"] == f"{math.degrees(limits.MAX_SPREAD_ANGLE):g}deg"


@pytest.mark.parametrize(("setting", "message"), [
    ("spread 1e300m", "`spread` 1e300m is above the maximum of 50cm"),
    ("spread 51cm", "`spread` 51cm is above the maximum of 50cm"),
    ("spread_angle 181deg", "`spread_angle` 181deg is above the maximum of 180deg"),
])
def test_a_spread_above_the_maximum(setting: str, message: str) -> None:
    [d] = check(prim(motion=f"keypoint reach = pos(target); {setting}")).diagnostics
    assert (d.code, d.message) == ("E0411", message)


def test_spreads_at_their_maxima_check_clean() -> None:
    text = prim(motion="keypoint reach = pos(target); spread 50cm; spread_angle 180deg")
    assert check(text).diagnostics == []


def test_an_exponent_beyond_the_loaders_bound_is_a_checker_error(tmp_path):
    from rapid_dsl.frontend.driver import check_text
    from rapid_dsl.language.limits import MAX_EXPONENT

    text = (f"def ok(x: Length) -> Real = (x / 1m) ^ -{MAX_EXPONENT}\n"
            f"def big(x: Length) -> Real = (x / 1m) ^ {MAX_EXPONENT + 1}\n"
            "def huge(x: Length) -> Real = (x / 1m) ^ 1e20\n")
    found = [(d.code, d.span.line) for d in check_text(text, "p.rapid").diagnostics]
    assert found == [("E0304", 2), ("E0304", 3)]
