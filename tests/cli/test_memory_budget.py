"""The memory a run will take is estimated from the scene and the settings before anything is
simulated, and a run above MAX_RUN_BYTES is refused (exit 2) with the knob to turn."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_file
from rapid_dsl.language.limits import MAX_RUN_BYTES
from rapid_dsl.runtime import memory
from rapid_dsl.runtime.config import RunConfig
from rapid_dsl.runtime.loader import load
from rapid_dsl.runtime.scenes.scene import load_scene
from rapid_dsl.runtime.scenes.world import build_world

from .box_scenes import boxes_scene

ROOT = Path(__file__).resolve().parents[2]
PUSH = ROOT / "tests" / "data" / "bind" / "push.rapid"   # strategy `shift`: one stdlib push

# Runs `rapidc ARGV` and prints its own peak resident memory (KiB) last on stderr: VmHWM of its
# own address space, since ru_maxrss also counts the parent's pages the child shared before its
# exec (a test process grown to 400 MB made every child look that large). Its address space is
# capped at 3 GiB, so a run that was not refused fails fast instead of filling the machine.
MEASURED = """\
import re, resource, sys
resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
from rapid_dsl.cli import main
code = main(sys.argv[1:])
with open("/proc/self/status") as status:
    print(re.search(r"VmHWM:\\s+(\\d+) kB", status.read())[1], file=sys.stderr)
sys.exit(code)
"""


def _measured(*argv: object) -> tuple[int, str, int]:
    """Exit status, stderr and peak memory [bytes] of `rapidc ARGV` in a new process."""
    done = subprocess.run([sys.executable, "-c", MEASURED, *map(str, argv)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300, check=False)
    *text, peak = done.stderr.rstrip("\n").split("\n")
    return done.returncode, "\n".join(text), int(peak) * 1024


def _estimate(scene: Path, config: RunConfig) -> memory.Estimate:
    loaded = load(compile_program(check_file(str(PUSH)).program).source, "shift")
    return memory.estimate(loaded.program, build_world(load_scene(scene)), "shift", config)


@pytest.fixture(scope="module")
def boxes(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    folder = tmp_path_factory.mktemp("boxes")
    return {n: boxes_scene(folder / f"boxes{n}.yaml", n) for n in (1, 16, 62)}


def test_the_estimate_grows_with_samples_steps_and_objects(boxes):
    base = _estimate(boxes[16], RunConfig(samples=64))
    double = _estimate(boxes[16], RunConfig(samples=128))
    fixed = base.sizes.fixed
    # the simulators' buffers are proportional to the population, all but the executed
    # elites' (at most `elites`, 6 for push)
    assert 1.8 < (double.bytes - fixed) / (base.bytes - fixed) < 2.0
    # a timestep half as long doubles the planning steps: 2.4 s of pushing, 4 keypoints that may
    # each wait 0.4 s for the grip, 0.5 s to settle: 4.5 s = 1,125 steps of 4 ms
    assert base.steps == 1125
    assert _estimate(boxes[16], RunConfig(samples=64, planning_dt=0.002)).steps == 2250
    # a state, sensors and a contact matrix that grow with the objects
    sizes = [_estimate(boxes[n], RunConfig(samples=64)) for n in (1, 16, 62)]
    assert [s.sizes.nstate for s in sizes] == [30, 225, 823]
    assert sizes[0].bytes < sizes[1].bytes < sizes[2].bytes


def test_a_refusal_says_how_many_samples_would_fit(boxes):
    loaded = load(compile_program(check_file(str(PUSH)).program).source, "shift")
    world = build_world(load_scene(boxes[62]))
    with pytest.raises(memory.MemoryBudgetError) as refused:
        memory.check(loaded.program, world, "shift", RunConfig(samples=1024))
    message = str(refused.value)
    assert message.startswith("the run needs about 12.3 GB of memory, more than the limit of "
                              "8.0 GB: phase `shove` simulates 1024 samples x 1,125 planning "
                              "steps of a scene of 63 objects (a state of 823 numbers, 3,431 "
                              "sensor values); lower --samples (at most ")
    assert message.endswith("fit), shorten the motion (`motion { duration }`), plan at a coarser "
                            "--planning-dt or use fewer objects")
    fits = int(message.split("at most ")[1].split(" ")[0])
    assert memory.estimate(loaded.program, world, "shift", RunConfig(), fits).bytes \
        <= MAX_RUN_BYTES < memory.estimate(loaded.program, world, "shift", RunConfig(),
                                           fits + 1).bytes
    # four parallel verification jobs count together
    with pytest.raises(memory.MemoryBudgetError, match=r"^4 runs at once need about .* or run "
                                                       r"fewer --jobs$"):
        memory.check(loaded.program, world, "shift", RunConfig(samples=256), copies=4)


@pytest.mark.slow
def test_a_huge_run_is_refused_before_it_allocates(boxes):
    # 62 objects at 1024 samples: about 12 GB; refused with the memory of the refusal itself.
    code, err, peak = _measured("run", PUSH, "--scene", boxes[62], "--bind", "box=b0",
                                "--samples", "1024", "--iterations", "1")
    assert code == 2, err
    assert err.startswith("rapidc: error: the run needs about 12.3 GB of memory"), err
    assert "lower --samples (at most" in err
    assert peak < 400 << 20


@pytest.mark.slow
def test_verify_refuses_jobs_that_together_need_too_much(rapidc, boxes):
    run = rapidc("verify", PUSH, "--scene", boxes[62], "--bind", "box=b0", "--samples", "256",
                 "--iterations", "1", "--variants", "2", "--jobs", "4")
    assert run.code == 2
    assert run.err.startswith("rapidc: error: 4 runs at once need about 13.1 GB (3.3 GB each)")


@pytest.mark.slow
def test_the_estimate_bounds_the_measured_peak_of_a_small_run(boxes):
    config = RunConfig(samples=32, iterations=1)
    code, err, peak = _measured("run", PUSH, "--scene", boxes[16], "--bind", "box=b0",
                                "--samples", "32", "--iterations", "1", "--quiet")
    assert code in (0, 1), err
    estimate = _estimate(boxes[16], config).bytes
    # an upper bound (it takes every keypoint as a grip change), but not a loose one
    assert 0.9 * peak < estimate < 1.6 * peak, (estimate, peak)
