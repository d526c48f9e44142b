"""Object-centric retargeting in segments on a real PlaceTubeOnBalance demo: the tube moved, the
reach and grasp follow it, the carry hands over to the balance (which stays), the placement holds."""

from __future__ import annotations

import numpy as np
import pytest

from pipette_cli.augment.objectcentric import adapt_actions
from pipette_cli.augment.simulate import ObjectOffset, settle_steps, simulate
from pipette_cli.demos.collect import collect
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.registry import load_registry
from pipette_cli.sim.world import World

OFFSET = ObjectOffset("tube", dx=-0.03, dy=-0.03, dyaw_deg=0.0)  # within 1.5 x the task's +-3 cm


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    task = load_registry([]).get("PlaceTubeOnBalance")
    path = tmp_path_factory.mktemp("place") / "raw.h5"
    result = collect(task, path, episodes=1, seed=0, image_size=16)
    assert result.added and result.added[0].success
    return task, read_episode(scan(path).episodes[0])


def test_a_moved_tube_is_placed_on_the_pan_when_the_carry_hands_over_to_the_balance(demo) -> None:
    task, episode = demo
    world = World(task)
    seed, state0, actions = episode.summary.seed, episode.arrays["sim_state"][0], episode.arrays["action"]
    ends = {}
    for hand_off in (True, False):
        adapted = adapt_actions(world, seed, state0, actions, OFFSET, ramp=15, hand_off=hand_off)
        rollout = simulate(world, seed, state0, adapted, settle_steps=settle_steps(world, 1.0), offset=OFFSET)
        ends[hand_off] = rollout.verdict, world.position("tube") - world.position("balance/pan_center")
        if hand_off:  # the descent and the release are the recorded ones
            np.testing.assert_array_equal(adapted[-20:], actions[-20:])
    (placed, gap), (whole, off) = ends[True], ends[False]
    assert placed.success, placed
    assert np.linalg.norm(gap[:2]) < 0.02
    # one segment for the whole demo sets the tube down where the pan would be had it moved with it
    assert not whole.success
    assert np.linalg.norm(off[:2]) > 0.03
