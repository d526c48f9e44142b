"""Contract tests over every registered task: build, reset, step, evaluate, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from pipette_cli.demos.embodiment import on_robot
from pipette_cli.errors import InfeasibleTask
from pipette_cli.registry import load_registry
from pipette_cli.sim.world import World

REGISTRY = load_registry()
TASK_IDS = REGISTRY.ids()
_WORLDS: dict[str, World] = {}


def world_for(task_id: str) -> World:
    if task_id not in _WORLDS:
        _WORLDS[task_id] = World(REGISTRY.get(task_id))
    return _WORLDS[task_id]


def hold_action(world: World) -> np.ndarray:
    return np.append(world.arm_qpos(), 1.0)


def rollout(world: World, seed: int, steps: int, rng_seed: int = 0) -> np.ndarray:
    """qpos after ``steps`` control steps of small random joint-target wiggles."""
    world.reset(seed)
    rng = np.random.default_rng(rng_seed)
    start = hold_action(world)
    for _ in range(steps):
        action = start + np.append(rng.normal(0, 0.02, world.robot.arm_dof), 0.0)
        world.step(action)
    return world.data.qpos.copy()


@pytest.mark.parametrize("task_id", TASK_IDS, ids=TASK_IDS)
def test_builds_resets_and_steps_without_nan(task_id: str) -> None:
    world = world_for(task_id)
    world.reset(seed=1)
    assert world.state().shape == (world.robot.arm_dof + 1,)
    np.testing.assert_allclose(world.arm_qpos(), REGISTRY.get(task_id).embodiment.initial_joints, atol=1e-9)
    for _ in range(10):
        world.step(hold_action(world))
    assert np.all(np.isfinite(world.data.qpos)) and np.all(np.isfinite(world.data.qvel))
    assert world.time == pytest.approx(10 * world.control_dt)


@pytest.mark.parametrize("task_id", TASK_IDS, ids=TASK_IDS)
def test_evaluator_is_false_at_reset_and_after_doing_nothing(task_id: str) -> None:
    world = world_for(task_id)
    world.reset(seed=2)
    assert not world.verdict.success
    verdict = world.step(hold_action(world))
    assert not verdict.success
    timeout = REGISTRY.get(task_id).success.timeout_s
    for _ in range(int(round(timeout / world.control_dt)) + 2):
        verdict = world.step(hold_action(world))
        if verdict.done:
            break
    assert verdict.failed and not verdict.success, verdict
    assert verdict.reason and verdict.metrics


@pytest.mark.parametrize("task_id", TASK_IDS, ids=TASK_IDS)
def test_same_seed_same_rollout(task_id: str) -> None:
    world = world_for(task_id)
    first = rollout(world, seed=7, steps=15)
    second = rollout(world, seed=7, steps=15)
    np.testing.assert_array_equal(first, second)


def test_seeds_randomise_the_initial_state() -> None:
    world = world_for("pipette/PickUpTestTube-v1")
    positions = []
    for seed in range(4):
        world.reset(seed)
        positions.append(world.position("tube"))
    xy = np.array(positions)[:, :2]
    assert len({tuple(np.round(p, 6)) for p in xy}) == 4
    assert np.all(np.abs(xy - [0.5, 0.0]) <= 0.04 + 1e-9)


def test_static_instruments_are_randomised_by_moving_their_base() -> None:
    world = world_for("pipette/CloseCentrifugeLid-v1")
    nominal = REGISTRY.get("pipette/CloseCentrifugeLid-v1").object("centrifuge").pose.pos
    world.reset(0)
    a = world.position("centrifuge")
    lid_a = world.joint("centrifuge/lid_hinge")
    world.reset(1)
    b = world.position("centrifuge")
    assert not np.allclose(a, b) and abs(b[0] - nominal[0]) <= 0.03 + 1e-9
    assert -45 - 1e-6 <= lid_a <= -39 + 1e-6


ROBOTS = ("franka_panda", "agilex_piper", "ur5e_2f85")


@pytest.mark.parametrize("task_id", TASK_IDS, ids=TASK_IDS)
def test_nothing_interpenetrates_at_reset_on_fifty_seeds_and_three_robots(task_id: str) -> None:
    # a randomised pose can push together what the nominal layout keeps apart (CloseCentrifugeLid's
    # open lid around the Panda's wrist on 43 of these seeds, until the centrifuge moved out)
    task = REGISTRY.get(task_id)
    found = {}
    for robot in ROBOTS:
        try:
            placed = on_robot(task, robot)
        except InfeasibleTask:  # refused up front, naming the limit: no scene to check
            continue
        world = World(placed, check=False)
        for seed in range(50):
            world.reset(seed)
            if problems := world.interpenetrations():
                found[robot, seed] = problems
    assert not found
