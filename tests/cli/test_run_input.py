"""`rapidc run` on bad input and on terminals: --arg values, MUJOCO_GL, colour and progress.

Runs that reach MuJoCo go through a new process (`python -m rapid_dsl`): MuJoCo reads MUJOCO_GL
once per process, and a terminal needs a pseudo-terminal. Usage errors run in-process.
"""

from __future__ import annotations

import ctypes.util
import os
import pty
import re
import select
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rapid_dsl.commands.arguments import ArgumentProblem, constant_value

ROOT = Path(__file__).resolve().parents[2]
PROGRAM = str(ROOT / "tests" / "data" / "run" / "shove.rapid")
SCENE = str(ROOT / "tests" / "data" / "run" / "tabletop.yaml")
SHOVE = ["run", PROGRAM, "--scene", SCENE, "--entry", "shove", "--samples", "4",
         "--iterations", "2", "--arg", "displacement=[6cm, 0cm, 0cm]"]
SGR = re.compile(rb"\x1b\[[0-9;]*m")   # colour and bold: Select Graphic Rendition


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("NO_COLOR", "FORCE_COLOR")}
    return {**env, **extra}


def _rapidc(*argv: str, **env: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rapid_dsl", *argv], cwd=ROOT, env=_env(**env),
                          capture_output=True, text=True, timeout=300, check=False)


def _on_terminal(*argv: str, **env: str) -> tuple[int, bytes]:
    """Exit status and everything `rapidc ARGV` wrote to a pseudo-terminal (stdout and stderr)."""
    leader, follower = pty.openpty()
    process = subprocess.Popen([sys.executable, "-m", "rapid_dsl", *argv], cwd=ROOT,
                               env=_env(**{"COLUMNS": "100", **env}), stdin=follower,
                               stdout=follower, stderr=follower)
    os.close(follower)
    output = b""
    try:
        while select.select([leader], [], [], 300)[0]:
            try:
                chunk = os.read(leader, 65536)
            except OSError:   # the pty closes when the process exits
                break
            if not chunk:
                break
            output += chunk
    finally:
        os.close(leader)
    return process.wait(timeout=60), output


# ------------------------------------------------------------------------------- --arg values

@pytest.mark.parametrize("value, message", [
    ("[1e400m, 0m, 0m]", "`1e400m` is too large: numbers are 64-bit floats"),
    ("[" + "9" * 5000 + "m, 0m, 0m]", "is too large"),
    ("[1e-400m, 0m, 0m]", "`1e-400m` is too small for a 64-bit float"),
    ("[1e308m * 10, 0m, 0m]", "`*` here has no finite value"),
    ("[10cm, 0cm, 0cm] * 1e308 * 1e308", "`*` here has no finite value"),
    ("[1m / 1e-320, 0m, 0m]", "`/` here has no finite value"),
    ("[2^2000 * 1cm, 0cm, 0cm]", "the exponent of `^` is at most 1024"),
    ("[(1e-300m)^-2 * 1m^3, 0m, 0m]", "`^` here has no finite value"),
    ("[0^-1 * 1m, 0m, 0m]", "`^` here has no finite value"),
    ("[nan, 0, 0]", "only constants are allowed"),
    ("[inf * 1m, 0m, 0m]", "only constants are allowed"),
    ("[1furlong, 0m, 0m]", "unknown unit `furlong`"),
    ("[1cm, 0cm]", "a vector literal has three quantities"),
    ("[1cm, 0cm, 0cm, 0cm]", "a vector literal has three quantities"),
    ("[1cm, 0cm, 0cm]; import os", "expected the end of the file"),
    ("__import__('os')", "--arg displacement"),
])
def test_bad_arg_values_are_usage_errors(rapidc, value, message):
    run = rapidc("run", PROGRAM, "--scene", SCENE, "--entry", "shove",
                 "--arg", f"displacement={value}")
    assert run.code == 2, run.err
    assert message in run.err and "Traceback" not in run.err
    assert len(run.err) < 400                     # a 5000-digit number is not echoed whole


@pytest.mark.parametrize("item", ["displacement=\x1b[31mred", "displacement=[1cm,0cm,0cm]\u202e",
                                  "displa\x1bcement=1cm", "\x07=1cm"])
def test_control_and_format_characters_in_args_are_shown_escaped(rapidc, item):
    run = rapidc("run", PROGRAM, "--scene", SCENE, "--entry", "shove", "--arg", item)
    assert run.code == 2
    assert "\x1b" not in run.err and "\u202e" not in run.err and "\x07" not in run.err
    assert "\\x1b" in run.err or "\\u202e" in run.err or "\\x07" in run.err


EXPRESSION_PARTS = ["1", "0", "9" * 400, "1e308", "1e-400", "2", ".5", "cm", "m", "deg", "kg",
                    "furlong", "e", "+", "-", "*", "/", "^", "(", ")", "[", "]", ",", " ", "pi",
                    "up", "nan", "inf", "\x00", "\u202e", "\u0301"]


@settings(max_examples=300, deadline=None, database=None, derandomize=True)
@given(st.lists(st.sampled_from(EXPRESSION_PARTS), max_size=25).map("".join))
def test_any_arg_text_is_a_finite_value_or_a_clean_problem(text):
    try:
        value = constant_value(text, "--arg x")
    except ArgumentProblem as problem:
        assert str(problem).isprintable()
    else:
        assert all(abs(float(v)) < float("inf") for v in value.value.reshape(-1))


# ------------------------------------------------------------------------------------ MUJOCO_GL

@pytest.mark.slow
def test_a_broken_gl_back_end_does_not_matter_without_video():
    run = _rapidc(*SHOVE, "--quiet", MUJOCO_GL="bogus")
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("shove: SUCCESS")


@pytest.mark.parametrize("backend", ["bogus", "disable"])
def test_a_broken_gl_back_end_is_a_usage_error_before_the_run(tmp_path, backend):
    run = _rapidc(*SHOVE, "--keyframes", str(tmp_path / "frames"), MUJOCO_GL=backend)
    assert run.returncode == 2, run.stderr
    assert f"MUJOCO_GL={backend}" in run.stderr and "MUJOCO_GL=egl" in run.stderr
    assert "Traceback" not in run.stderr
    assert "iteration" not in run.stderr          # refused before minutes of optimization
    assert not (tmp_path / "frames").exists()


@pytest.mark.slow
@pytest.mark.skipif(ctypes.util.find_library("OSMesa") is not None, reason="OSMesa is installed")
def test_osmesa_without_the_library_names_the_package(tmp_path):
    run = _rapidc(*SHOVE, "--video", str(tmp_path / "run.mp4"), MUJOCO_GL="osmesa")
    assert run.returncode == 2, run.stderr
    assert "MUJOCO_GL=osmesa cannot start" in run.stderr and "libosmesa6" in run.stderr
    assert _rapidc(*SHOVE, "--quiet", MUJOCO_GL="osmesa").returncode == 0


# ----------------------------------------------------------------------- colour and progress

@pytest.mark.slow
def test_the_progress_bar_has_its_total_from_the_first_frame():
    code, output = _on_terminal(*SHOVE, "--color", "never")
    assert code == 0, output
    frames = [f for f in re.split(rb"[\r\n]", output) if b"shove (shove)" in f]
    assert frames, output
    assert b"0/2" in frames[0] and b"None" not in output


@pytest.mark.slow
@pytest.mark.parametrize("how", [{"argv": ("--color", "never")}, {"env": {"NO_COLOR": "1"}}])
def test_no_colour_on_a_terminal_means_no_styling_at_all(how):
    code, output = _on_terminal(*SHOVE, *how.get("argv", ()), **how.get("env", {}))
    assert code == 0, output
    assert b"SUCCESS" in output and b"phase" in output
    assert not SGR.search(output), output


@pytest.mark.slow
def test_a_terminal_of_width_0_still_gets_the_table():
    code, output = _on_terminal(*SHOVE, COLUMNS="0")
    assert code == 0 and b"SUCCESS" in output and b"planned cost" in output


@pytest.mark.slow
def test_a_terminal_gets_colour_by_default_and_a_pipe_only_when_asked():
    code, output = _on_terminal(*SHOVE)
    assert code == 0 and SGR.search(output)
    piped = _rapidc(*SHOVE, FORCE_COLOR="1", TTY_COMPATIBLE="1")
    assert piped.returncode == 0 and "\x1b" not in piped.stdout + piped.stderr
    asked = _rapidc(*SHOVE, "--color", "always", NO_COLOR="1")
    assert asked.returncode == 0 and SGR.search(asked.stdout.encode())


@pytest.mark.slow
def test_program_and_path_text_in_the_table_is_not_rich_markup(tmp_path):
    program = tmp_path / "shove.rapid"
    program.write_text(Path(PROGRAM).read_text(encoding="utf-8")
                       .replace("    miss < 3cm\n", "    norm([miss, 0cm, 0cm]) < 3cm\n"),
                       encoding="utf-8")
    scene = tmp_path / "[lab]" / "tabletop.yaml"
    scene.parent.mkdir()
    scene.write_text(Path(SCENE).read_text(encoding="utf-8"), encoding="utf-8")
    run = _rapidc("run", str(program), "--scene", str(scene), *SHOVE[4:])
    assert run.returncode == 0, run.stderr
    assert "shove: norm([miss, 0cm, 0cm]) < 3cm" in run.stdout   # not `norm() < 3cm`
    assert f"on {scene}, seed 0" in run.stdout


@pytest.mark.parametrize("option, value, message", [
    ("--video", "run.webm", "must end in .mp4, .mkv, .mov, .avi"),
    ("--video", "run.mpg", "must end in .mp4"),
    ("--video", "run", "must end in .mp4"),
    ("--video", "", "--video: needs a file name"),
    ("--trace", "", "--trace: needs a file name"),
    ("--keyframes", " ", "--keyframes: needs a file name"),
])
def test_output_names_are_checked_before_the_run(rapidc, tmp_path, option, value, message):
    path = str(tmp_path / value) if value.strip() else value
    run = rapidc(*SHOVE, f"{option}={path}")
    assert run.code == 2 and message in run.err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_an_interrupted_run_exits_130_with_one_line():
    process = subprocess.Popen([sys.executable, "-m", "rapid_dsl", *SHOVE, "--samples", "64",
                                "--iterations", "100"], cwd=ROOT, env=_env(),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stderr is not None
    for line in process.stderr:              # optimizing: interrupt in the middle of the CEM
        if "iteration 2/100" in line:
            break
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130
    assert err.strip().splitlines()[-1] == "rapidc: interrupted" and "Traceback" not in err
    assert out == ""


@pytest.mark.slow
def test_overflowing_program_arithmetic_is_a_failure_without_numpy_warnings(tmp_path):
    program = tmp_path / "far.rapid"
    program.write_text(Path(PROGRAM).read_text(encoding="utf-8").replace(
        "keypoint through = behind + horizontal(displacement)",
        "keypoint through = behind + [1e300m, 0m, 0m]"), encoding="utf-8")
    run = _rapidc("run", str(program), *SHOVE[2:], "--quiet")
    assert run.returncode == 1, run.stderr
    assert run.stdout.startswith("shove: FAILED")
    assert "is false: NaN vs 3cm" in run.stdout            # not `nancm`
    assert "Warning" not in run.stderr and "Traceback" not in run.stderr


@pytest.mark.slow
def test_keyframes_and_video_onto_a_file_say_so(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    run = _rapidc(*SHOVE, "--quiet", "--keyframes", str(blocker),
                  "--video", str(blocker / "run.mp4"))
    assert run.returncode == 2, run.stderr
    assert f"cannot write key frames to `{blocker}`: {blocker}: a file, not a folder" \
        in run.stderr
    assert f"cannot write video `{blocker / 'run.mp4'}`: {blocker}: a file, not a folder" \
        in run.stderr
    assert "Errno" not in run.stderr


@pytest.mark.slow
def test_a_solve_that_overflows_fails_quietly(tmp_path):
    program = tmp_path / "keep_clear.rapid"
    text = (ROOT / "examples" / "keep_clear.rapid").read_text(encoding="utf-8")
    program.write_text(re.sub(r"subject \{ .* \}", "subject { d.x == 1e300m }", text),
                       encoding="utf-8")
    run = _rapidc("run", str(program), "--scene", str(ROOT / "examples" / "scenes" /
                                                      "flip_box.yaml"), "--quiet")
    assert run.returncode == 1, run.stderr
    assert "solve for `d` failed" in run.stdout
    assert "CasADi" not in run.stderr and "WARNING" not in run.stderr
