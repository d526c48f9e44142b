"""Gymnasium environments for every registered task: ``gymnasium.make("pipette/PickUpTestTube-v1")``.

Observations follow LeRobot's gym convention (so ``lerobot-eval`` maps them onto
``observation.images.top|main|wrist`` and ``observation.state``):
``{"pixels": {"top", "main", "wrist": uint8 HxWx3}, "agent_pos": float32 (dof+1,)}``;
actions are ``Box`` joint targets within the arm's limits plus a gripper command in [0, 1]
(>= 0.5 opens). Reward is 1 on the step the task's evaluator succeeds. The episode
terminates on success or failure (failure includes the task's timeout).
Importing :mod:`pipette_cli.envs` registers every task (see there).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from pipette_cli.registry import load_registry
from pipette_cli.sim.env import Observation, PipetteEnv
from pipette_cli.sim.render import Profile
from pipette_cli.sim.views import views_sheet

STATE_MARGIN = 0.05
"""Radians (metres for slides) by which observed joints may pass their limits."""


class PipetteGymEnv(gym.Env[dict[str, Any], np.ndarray]):
    """Gymnasium view of :class:`~pipette_cli.sim.env.PipetteEnv`."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    @property
    def task(self) -> str:
        """The language instruction of the moment (LeRobot reads ``task`` and ``task_description``):
        on a protocol, the current stage's."""
        return self.env.world.instruction()

    @property
    def task_description(self) -> str:
        return self.task

    def __init__(
        self,
        task_id: str,
        image_size: int | None = None,
        render_profile: Profile = "fast",
        render_mode: str | None = None,
    ) -> None:
        self.spec_task = load_registry().get(task_id)
        self.env = PipetteEnv(self.spec_task, image_size=image_size, render_profile=render_profile)
        self.render_mode = render_mode
        world = self.env.world
        h = image_size or self.spec_task.cameras.height
        w = image_size or self.spec_task.cameras.width
        image = spaces.Box(0, 255, shape=(h, w, 3), dtype=np.uint8)
        self.observation_space = spaces.Dict(
            {
                "pixels": spaces.Dict({"top": image, "main": image, "wrist": image}),
                # joint limits are soft in MuJoCo: allow a small overshoot
                "agent_pos": spaces.Box(
                    np.append(world.arm_range[:, 0], world.gripper_range[0]).astype(np.float32) - STATE_MARGIN,
                    np.append(world.arm_range[:, 1], world.gripper_range[1]).astype(np.float32) + STATE_MARGIN,
                    dtype=np.float32,
                ),
            }
        )
        low = np.append(world.arm_range[:, 0], 0.0).astype(np.float32)
        high = np.append(world.arm_range[:, 1], 1.0).astype(np.float32)
        self.action_space = spaces.Box(low, high, dtype=np.float32)
        self._last: Observation | None = None

    def _obs(self, obs: Observation) -> dict[str, Any]:
        self._last = obs
        # copies: gymnasium requires every call to return fresh arrays, and stale steps reuse frames
        return {"pixels": {k: v.copy() for k, v in obs.images.items()}, "agent_pos": obs.state.astype(np.float32)}

    def _info(self, obs: Observation, verdict: Any = None) -> dict[str, Any]:
        info: dict[str, Any] = {"fresh": obs.fresh, "frame_age": obs.frame_age, "sim_time": obs.sim_time}
        if verdict is not None:
            info.update(is_success=verdict.success, failure_reason=verdict.reason, metrics=dict(verdict.metrics))
        return info

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        episode_seed = int(self.np_random.integers(0, 2**31 - 1)) if seed is None else seed
        obs = self.env.reset(episode_seed)
        return self._obs(obs), self._info(obs)

    def step(self, action: np.ndarray):
        obs, verdict = self.env.step(np.asarray(action, dtype=float))
        reward = 1.0 if verdict.success else 0.0
        return self._obs(obs), reward, verdict.done, False, self._info(obs, verdict)

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the last observation's views side by side, each labelled."""
        if self.render_mode != "rgb_array" or self._last is None:
            return None
        return views_sheet(self._last.images, gap=0)

    def close(self) -> None:
        self.env.close()


def register_envs() -> None:
    """Register every task of the registry with gymnasium.

    Gymnasium 1.x has no plugin entry points: importing :mod:`pipette_cli.envs` calls this, and
    ``gym.make("pipette_cli.envs:pipette/PickUpTestTube-v1")`` imports that module itself.
    """
    registry = load_registry()
    for task_id in registry.ids():
        if task_id not in gym.registry:
            task = registry.get(task_id)
            steps = int(round((task.success.timeout_s or 60.0) * task.timing.control_hz)) + 1
            gym.register(
                id=task_id,
                entry_point=PipetteGymEnv,  # type: ignore[arg-type]  # gymnasium types it as a creator function
                kwargs={"task_id": task_id},
                max_episode_steps=steps,
                disable_env_checker=True,
            )
