"""Cameras, the 30/10 Hz timing bookkeeping, gymnasium registration and env_checker."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import pipette_cli.envs  # noqa: F401  (registers the tasks)
from pipette_cli.registry import load_registry
from pipette_cli.sim.env import PipetteEnv

pytestmark = pytest.mark.render
TASK_IDS = load_registry().ids()


def test_fresh_flags_and_frame_age_follow_paper_a3() -> None:
    env = PipetteEnv(load_registry().get("PickUpTestTube"), image_size=48)
    obs = env.reset(0)
    flags, ages = [obs.fresh], [obs.frame_age]
    frames = [obs.images["main"]]
    hold = np.append(env.world.arm_qpos(), 1.0)
    for _ in range(6):
        obs, _ = env.step(hold)
        flags.append(obs.fresh)
        ages.append(obs.frame_age)
        frames.append(obs.images["main"])
    env.close()
    assert flags == [True, False, False, True, False, False, True]
    assert ages == [0, 1, 2, 0, 1, 2, 0]
    assert frames[1] is frames[0] and frames[2] is frames[0]  # stale steps reuse the last frame
    assert frames[3] is not frames[0]  # a fresh step renders anew
    assert obs.sim_time == pytest.approx(6 / 30)
    assert obs.images["top"].shape == (48, 48, 3) and obs.images["top"].dtype == np.uint8


def test_three_views_differ_and_are_not_blank() -> None:
    env = PipetteEnv(load_registry().get("PlaceTubeOnBalance"), image_size=64)
    env.reset(0)
    views = env.render_views()
    env.close()
    assert set(views) == {"top", "main", "wrist"}
    for image in views.values():
        assert image.std() > 5, "a view is blank"
    assert not np.array_equal(views["top"], views["main"])


def test_full_and_fast_profiles_render_the_same_scene() -> None:
    task = load_registry().get("PickUpTestTube")
    images = {}
    for profile in ("fast", "full"):
        env = PipetteEnv(task, image_size=64, render_profile=profile)
        env.reset(0)
        images[profile] = env.render_views()["main"].astype(float)
        env.close()
    difference = np.abs(images["fast"] - images["full"]).mean()
    assert 0 < difference < 40  # shadows and MSAA change pixels, not the scene


@pytest.mark.parametrize("task_id", TASK_IDS, ids=TASK_IDS)
def test_gymnasium_make_and_env_checker(task_id: str) -> None:
    env = gym.make(task_id, image_size=32)
    try:
        check_env(env.unwrapped, skip_render_check=True)
        obs, info = env.reset(seed=3)
        assert obs["agent_pos"].shape == env.observation_space["agent_pos"].shape
        assert set(obs["pixels"]) == {"top", "main", "wrist"}
        obs2, _ = env.reset(seed=3)
        np.testing.assert_array_equal(obs["pixels"]["main"], obs2["pixels"]["main"])
        obs, reward, _terminated, truncated, info = env.step(env.action_space.sample())
        assert reward == 0.0 and not truncated and "is_success" in info
    finally:
        env.close()
