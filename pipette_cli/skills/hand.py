"""The hand as the skills plan it: the tool pose and joints after the last planned move, the gripper,
what it holds (measured in the hand) and what it may touch.

The planner (:mod:`.reach`, :mod:`.transit`) reads this state; the skill context
(:mod:`.runtime`) commands it, one move at a time.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from functools import cached_property

import numpy as np
from mink.utils import get_subtree_body_ids

from pipette_cli.sim.scene import ROBOT_PREFIX
from pipette_cli.sim.world import World
from pipette_cli.skills.moves import CLOSED, OPEN, Held, SkillFailure
from pipette_cli.skills.scene import SceneQuery

FINGERTIP = 0.012
"""Metres the fingertips reach below the tcp (an empty hand's hang over a surface)."""
FINGER_BEYOND = 0.001
"""Metres past the tcp along the approach from which the hand's geometry counts as reaching beyond it."""


class Hand:
    """The planned tool state after the last move and what is in the hand (see the module docstring)."""

    def __init__(self, world: World, scene: SceneQuery) -> None:
        self.world = world
        self.scene = scene
        self.pos = world.tcp_position()
        self.rot = world.tcp_rotation()
        self.q = world.arm_qpos()
        self.gripper = OPEN if world.task.embodiment.gripper == "open" else CLOSED
        self.held: Held | None = None
        self.allowed: set[int] = set()
        """Bodies the hand may touch while moving through free space (set by a skill around a contact)."""

    @contextmanager
    def touching(self, bodies: set[int]) -> Iterator[None]:
        """Allow the hand to touch ``bodies`` (what it grasps, pushes or presses) inside the block."""
        before = self.allowed
        self.allowed = before | set(bodies)
        try:
            yield
        finally:
            self.allowed = before

    @cached_property
    def finger_corners(self) -> np.ndarray:
        """Corners of the boxes round the hand's colliding geoms that lie beyond the tcp along the
        approach, in the tool frame (n, 3): the fingers as the model has them (measured once, at the
        episode's start; the fingers slide along the closing axis, which moves no corner along the
        other two)."""
        m, d = self.world.model, self.world.data
        hand = set(get_subtree_body_ids(m, m.body(ROBOT_PREFIX + self.world.robot.end_effector.body).id))
        tcp, rot = self.world.tcp_position(), self.world.tcp_rotation()
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        out = []
        for g in range(m.ngeom):
            if m.geom_bodyid[g] not in hand or not (m.geom_contype[g] or m.geom_conaffinity[g]):
                continue
            center, half = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
            local = center + signs * half
            world = d.geom_xpos[g] + local @ d.geom_xmat[g].reshape(3, 3).T
            out.append((world - tcp) @ rot)
        corners = np.concatenate(out) if out else np.zeros((1, 3))
        beyond = corners[corners[:, 2] > FINGER_BEYOND]
        return beyond if len(beyond) else np.zeros((1, 3))

    # ------------------------------------------------------------------ holding
    def attach(self, name: str) -> Held:
        """Record ``name`` as held, measuring where it sits in the hand now."""
        tcp_pos, tcp_rot = self.world.tcp_position(), self.world.tcp_rotation()
        held = Held(name, tcp_rot.T @ (self.world.position(name) - tcp_pos), tcp_rot.T @ self.world.rotation(name))
        self.held = held
        return held

    def holding(self, name: str) -> Held:
        """The held object ``name`` (measured again now); raises when the hand holds something else."""
        if self.held is None or self.held.name != name:
            have = f"it holds {self.held.name!r}" if self.held else "the hand is empty"
            raise SkillFailure(f"{name!r} is not in the hand ({have}); pick it first")
        return self.attach(name)

    def check_holding(self, name: str, tolerance: float = 0.02) -> None:
        """Raise unless ``name`` still sits where it was grasped in the hand (it did not slip out)."""
        if self.held is None:
            return
        tcp_pos, tcp_rot = self.world.tcp_position(), self.world.tcp_rotation()
        expected = tcp_pos + tcp_rot @ self.held.pos
        slip = float(np.linalg.norm(self.world.position(name) - expected))
        if slip > tolerance:
            raise SkillFailure(
                f"the grasp on {name!r} did not hold (it is {slip * 1000:.0f} mm from where it was held)"
            )

    def tool_for(self, name: str, origin: np.ndarray, rot: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The tcp pose that puts held object ``name``'s origin at ``origin`` (rotation ``rot``, or as held)."""
        held = self.holding(name) if self.held is None or self.held.name != name else self.held
        tool_rot = self.rot if rot is None else rot @ held.rot.T
        return origin - tool_rot @ held.pos, tool_rot

    def hang(self) -> float:
        """How far below the tcp the hand and what it holds reach (for clearance over surfaces)."""
        if self.held is None:
            return FINGERTIP
        shape = self.scene.shape(self.held.name)
        return max(FINGERTIP, float(self.pos[2] - shape.bottom + 0.0))

    def hang_at(self, rot: np.ndarray) -> float:
        """How far below the tcp the hand and what it holds would reach with the tool turned to ``rot``
        (what it holds keeping its place in the hand)."""
        if self.held is None:
            return FINGERTIP
        shape = self.scene.shape(self.held.name)
        center = shape.axes.T @ (shape.center - self.world.position(self.held.name))  # in the object's frame
        turned = rot @ self.held.rot
        lowest = (rot @ self.held.pos)[2] + (turned @ center)[2] - np.abs(turned[2]) @ shape.half
        return max(FINGERTIP, float(-lowest))

    def held_bodies(self) -> set[int]:
        """The bodies of what the hand holds (they move with it), or none."""
        return self.scene.bodies(self.held.name) if self.held else set()
