"""Object-centric retargeting in segments (MimicGen's subtasks): which object's frame the part of a
demo after the grasp belongs to, read off the task's skill program, and the hand-off blend."""

from __future__ import annotations

import numpy as np
import pytest

from pipette_cli.augment.objectcentric import destination, handoff_weights
from pipette_cli.demos.experts.base import expert_program
from pipette_cli.registry import load_registry

REGISTRY = load_registry()


@pytest.mark.parametrize(
    ("task_id", "moved", "frame"),
    [
        ("PlaceTubeOnBalance", "tube", "balance"),  # place_on balance/pan_center
        ("protocols/UnloadMicrocentrifuge-v1", "tube", "rack"),  # insert_into a rack hole
        ("PipetteToPetriDish", "pipette", "dish"),  # position_over dish/center
        ("RemoveTubeFromBalance", "tube", "tube"),  # set down beside where it stood: its own start
        ("PickUpTestTube", "tube", None),  # picked and held: no step takes it anywhere
        ("OpenWaterBathLid", "lid", None),  # moved by an offset from where the hand is
        ("CloseCentrifugeLid", "centrifuge", None),
    ],
)
def test_the_frame_after_the_grasp_is_read_off_the_skill_program(task_id: str, moved: str, frame: str | None) -> None:
    program, _ = expert_program(REGISTRY.get(task_id))
    assert destination(program, moved) == frame


def test_the_object_s_transform_is_kept_through_the_grasp_and_blended_out_over_half_the_carry() -> None:
    gripper = np.array([1.0] * 10 + [0.0] * 40 + [1.0] * 10)  # closes at step 10, opens at step 50
    w = handoff_weights(gripper, lag=6)
    assert w is not None
    assert np.all(w[:17] == 1.0)  # until 6 steps after the close (the fingers close, the hand stands)
    assert np.all(np.diff(w) <= 0) and 0 < w[20] < 1  # then down, never back up
    assert np.all(w[16 + 17 :] == 0.0)  # gone by half the 34 steps left to the release: the recorded descent
    assert handoff_weights(np.ones(20), lag=6) is None  # never closes
    assert handoff_weights(np.array([1.0] * 5 + [0.0] * 15), lag=6) is None  # never lets go
