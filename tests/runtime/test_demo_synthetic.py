"""The demonstration analysis recovers known effects from synthetic tracks (tests/runtime/
demo_tracks.py): pure translation, rotation about a tilted axis, a lift, pauses between phases,
noise; within 1 cm and 3 deg. Each phase's kind and argument follow docs/demos.md."""

from __future__ import annotations

import math

import numpy as np
import pytest
from demo_tracks import (
    angle_between,
    grasp,
    lift,
    pause,
    slide,
    synthetic,
    turn,
)
from hypothesis import given, settings
from hypothesis import strategies as st

from rapid_dsl.runtime.demonstrations.analysis import analyze_track

CM = 0.01
DEG = math.radians(1)
NOISE = {"noise": 0.001, "angle_noise": 0.3 * DEG}     # 1 mm and 0.3 deg per frame


def close(measured: list[float], truth: tuple[float, ...], tolerance: float = 1 * CM) -> bool:
    return float(np.linalg.norm(np.subtract(measured, truth))) <= tolerance


def test_a_pure_translation_is_one_push_by_its_displacement() -> None:
    analysis = analyze_track(synthetic([pause(1), slide(0.12, 0.05), pause(1)], **NOISE))
    [phase] = analysis["phases"]
    assert phase["kind"] == "push" and phase["object"] == "box"
    effect = phase["effect"]
    assert close(effect["displacement"], (0.12, 0.05, 0.0))
    assert abs(effect["distance"] - 0.13) <= 1 * CM
    assert effect["rotation_angle"] <= 3 * DEG
    assert close(phase["arguments"]["displacement"], (0.12, 0.05, 0.0))
    assert phase["argument_units"] == {"displacement": "m"}
    assert phase["support"] == "table" and phase["hand"]["near"] > 0.9
    assert 1.0 <= phase["start"] < phase["end"] <= 2.6


@pytest.mark.parametrize("axis", [(1, 1, 1), (0.2, -1, 0.6), (1, 0, 0.3)])
def test_a_rotation_about_a_tilted_axis_gives_its_angle_and_axis(axis) -> None:
    analysis = analyze_track(synthetic([pause(1), turn(axis, 60), pause(1)], **NOISE))
    [phase] = analysis["phases"]
    effect = phase["effect"]
    assert abs(effect["rotation_angle"] - 60 * DEG) <= 3 * DEG
    assert angle_between(effect["rotation_axis"], axis) <= 3 * DEG
    assert effect["distance"] <= 1 * CM            # it turned in place
    assert phase["kind"] == "topple"               # tipped, no fixture near


def test_a_grasp_then_a_lift_gives_the_grasp_and_the_lift_height() -> None:
    analysis = analyze_track(synthetic([pause(1), grasp(), pause(0.5), lift(0.12), pause(1)],
                                       **NOISE))
    kinds = [p["kind"] for p in analysis["phases"]]
    assert kinds == ["grasp", "lift"]
    grasped, lifted = analysis["phases"]
    assert grasped["arguments"] == {"approach": [0.0, 0.0, -1.0]}
    assert abs(lifted["effect"]["lift_height"] - 0.12) <= 1 * CM
    assert abs(lifted["arguments"]["rise"] - 0.12) <= 1 * CM
    assert lifted["hand"]["held"] > 0.9
    assert lifted["argument_text"] == {"rise": "12cm"}


def test_pauses_separate_phases_and_each_keeps_its_own_effect() -> None:
    steps = [pause(1), slide(0.1, 0), pause(0.6), turn((0, 0, 1), 45), pause(0.5),
             slide(0, -0.08), pause(1)]
    analysis = analyze_track(synthetic(steps, noise=0.0015, angle_noise=0.5 * DEG, seed=3))
    first, second, third = analysis["phases"]
    assert [first["kind"], second["kind"], third["kind"]] == ["push", "pivot", "push"]
    assert close(first["effect"]["displacement"], (0.1, 0, 0))
    assert abs(second["arguments"]["angle"] - 45 * DEG) <= 3 * DEG
    assert close(second["effect"]["displacement"], (0, 0, 0))
    assert close(third["effect"]["displacement"], (0, -0.08, 0))
    assert first["end"] < second["start"] and second["end"] < third["start"]


def test_a_turn_the_other_way_about_the_vertical_is_a_negative_pivot() -> None:
    [phase] = analyze_track(synthetic([pause(1), turn((0, 0, 1), -70), pause(1)]))["phases"]
    assert phase["kind"] == "pivot"
    assert abs(phase["arguments"]["angle"] + 70 * DEG) <= 3 * DEG


def test_a_push_straight_into_a_tip_without_a_pause_is_two_phases() -> None:
    steps = [pause(1), slide(0.1, 0), turn((0, 1, 0), 80, about=(0.06, 0, -0.02)), pause(1)]
    pushed, tipped = analyze_track(synthetic(steps, **NOISE))["phases"]
    assert pushed["kind"] == "push" and close(pushed["effect"]["displacement"], (0.1, 0, 0))
    assert abs(tipped["effect"]["rotation_angle"] - 80 * DEG) <= 3 * DEG


def test_without_motion_there_is_no_phase() -> None:
    analysis = analyze_track(synthetic([pause(2)], **NOISE))
    assert analysis["phases"] == [] and analysis["objects"]["box"]["moved"] is False


def test_uneven_frame_times_are_read_as_times() -> None:
    """A track whose frames come at uneven times (dropped video frames) gives the same effect."""
    track = synthetic([pause(1), slide(0.1, 0.04), pause(1)], rate=50.0, **NOISE)
    rng = np.random.default_rng(5)
    keep = sorted({0, len(track["frames"]) - 1}
                  | set(rng.choice(len(track["frames"]), size=60, replace=False).tolist()))
    track["frames"] = [track["frames"][i] for i in keep]
    [phase] = analyze_track(track)["phases"]
    assert close(phase["effect"]["displacement"], (0.1, 0.04, 0))


# --- any sequence ------------------------------------------------------------------------------

slides = st.builds(lambda length, heading: ("slide", length, heading),
                   st.floats(0.04, 0.2), st.floats(-math.pi, math.pi))
turns = st.builds(lambda degrees, axis: ("turn", degrees, axis), st.floats(30, 110),
                  st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(
                      lambda a: math.dist(a, (0, 0, 0)) > 0.3))


@pytest.mark.slow
@settings(max_examples=40, deadline=None)
@given(moves=st.lists(st.one_of(slides, turns), min_size=1, max_size=3),
       pauses=st.lists(st.floats(0.5, 1.5), min_size=3, max_size=3),
       noise=st.floats(0.0, 0.0015), rate=st.sampled_from([10.0, 25.0, 50.0]),
       seed=st.integers(0, 2**16))
def test_any_sequence_of_slides_and_turns_with_pauses_is_recovered(moves, pauses, noise, rate,
                                                                   seed) -> None:
    steps, truth = [pause(1.0)], []
    for k, move in enumerate(moves):
        if move[0] == "slide":
            _, length, heading = move
            vector = (length * math.cos(heading), length * math.sin(heading), 0.0)
            steps.append(slide(*vector))
            truth.append((vector, 0.0, None))
        else:
            _, degrees, axis = move
            steps.append(turn(axis, degrees))
            truth.append(((0.0, 0.0, 0.0), degrees * DEG, axis))
        steps.append(pause(pauses[k]))
    # 0.3 deg of orientation noise per mm of position noise
    analysis = analyze_track(synthetic(steps, rate=rate, noise=noise,
                                       angle_noise=noise * 300 * DEG, seed=seed))
    assert len(analysis["phases"]) == len(truth)
    for phase, (vector, angle, axis) in zip(analysis["phases"], truth, strict=True):
        effect = phase["effect"]
        assert close(effect["displacement"], vector)
        assert abs(effect["rotation_angle"] - angle) <= 3 * DEG
        if axis is not None:
            assert angle_between(effect["rotation_axis"], axis) <= 3 * DEG
