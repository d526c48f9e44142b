"""The control loop of paper A.3: 30 Hz control, 10 Hz vision, fresh flags and frame age.

:class:`PipetteEnv` wraps a :class:`~pipette_cli.sim.world.World` with cameras. Observation
k is taken before action k; a new camera frame is rendered when ``(k - 1) mod d_v == 0``
(``fresh``), otherwise the last frame is reused and ``frame_age`` counts control steps since
it was taken. Timestamps: simulated time ``n_sim * dt`` and wall-clock time.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.render import CameraRig, Profile, find_profile
from pipette_cli.sim.scene import CAMERA_NAMES
from pipette_cli.sim.world import World
from pipette_cli.specs.task import TaskSpec


@dataclass
class Observation:
    """Everything recorded per control step (paper A.3)."""

    images: dict[str, np.ndarray]
    state: np.ndarray
    fresh: bool
    frame_age: int
    sim_time: float
    wall_time: float
    step: int
    instruction: str
    """The language instruction of this step: the current stage's own on a protocol task."""
    stage: int = 0
    """Stages of the task's ``sequence`` criterion completed before this step (0 for other tasks)."""
    instrument: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The scene's instrument values (``World.instrument_names``) before this step."""
    extra: dict[str, object] = field(default_factory=dict)


class PipetteEnv:
    """A task with its cameras; the one loop used by experts, teleop, recording and evaluation.

    Args:
        task: The task spec.
        image_size: Square image side in pixels (default: the task's cameras, 400).
        render_profile: ``fast`` or ``full``.
        render: When False no GL context is made and ``images`` stay empty (physics-only
            rollouts, e.g. augmentation verification).
    """

    def __init__(
        self, task: TaskSpec, *, image_size: int | None = None, render_profile: Profile = "fast", render: bool = True
    ) -> None:
        self.task = task
        self.image_size, self.render_profile = image_size, render_profile
        meshes = find_profile(render_profile).meshes if render else "full"
        self.world = World(task, meshes=meshes)
        width = image_size or task.cameras.width
        height = image_size or task.cameras.height
        self.rig = CameraRig(self.world.model, width, height, render_profile) if render else None
        self.vision_every = task.timing.vision_every
        self._images: dict[str, np.ndarray] = {}
        self._last_fresh = 0
        self._wall0 = 0.0

    @property
    def action_dim(self) -> int:
        return self.world.action_dim

    def _observe(self) -> Observation:
        k = self.world.step_count + 1
        fresh = (k - 1) % self.vision_every == 0
        if fresh:
            self._last_fresh = k
            if self.rig is not None:
                self._images = self.rig.render_all(self.world.data)
        return Observation(
            images=dict(self._images),
            state=self.world.state(),
            fresh=fresh,
            frame_age=k - self._last_fresh,
            sim_time=self.world.time,
            wall_time=time.perf_counter() - self._wall0,
            step=k,
            instruction=self.world.instruction(),
            stage=self.world.stage,
            instrument=self.world.instrument_state(),
        )

    def reset(self, seed: int) -> Observation:
        self.world.reset(seed)
        self._wall0 = time.perf_counter()
        self._last_fresh = 0
        return self._observe()

    def observe(self) -> Observation:
        """Observe again without stepping (after changing the scene between reset and the first step)."""
        return self._observe()

    def step(self, action: np.ndarray) -> tuple[Observation, Verdict]:
        verdict = self.world.step(action)
        return self._observe(), verdict

    def render_views(self) -> dict[str, np.ndarray]:
        """Render the three cameras now, regardless of the vision schedule."""
        if self.rig is None:
            raise RuntimeError("this env was created with render=False")
        return self.rig.render_all(self.world.data)

    def close(self) -> None:
        if self.rig is not None:
            self.rig.close()
            self.rig = None


__all__ = ["CAMERA_NAMES", "Observation", "PipetteEnv"]
