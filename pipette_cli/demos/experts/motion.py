"""Waypoint motion for scripted experts: straight-line tcp moves solved by damped least squares.

A plan is a list of :class:`Segment` s. Each segment moves the tool centre point from where
the previous one ended to ``pos`` (and ``rot``) along a straight line with a smooth
(minimum-jerk) time profile over ``steps`` control steps, with the gripper held at
``gripper`` (1 open, 0 closed). IK is warm-started from the last solution, so consecutive
steps produce continuous joint targets.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from pipette_cli.sim.controllers import DifferentialIK
from pipette_cli.sim.world import World


def yaw_down(yaw: float) -> np.ndarray:
    """Rotation with the tcp's z axis pointing down and its x axis at ``yaw`` (radians) in the plane."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


def slerp_rot(r0: np.ndarray, r1: np.ndarray, t: float) -> np.ndarray:
    q0, q1 = np.zeros(4), np.zeros(4)
    mujoco.mju_mat2Quat(q0, r0.flatten())
    mujoco.mju_mat2Quat(q1, r1.flatten())
    if np.dot(q0, q1) < 0:
        q1 = -q1
    omega = np.arccos(np.clip(np.dot(q0, q1), -1.0, 1.0))
    if omega < 1e-6:
        q = q1
    else:
        q = (np.sin((1 - t) * omega) * q0 + np.sin(t * omega) * q1) / np.sin(omega)
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, q / np.linalg.norm(q))
    return mat.reshape(3, 3)


def min_jerk(t: float) -> float:
    return t**3 * (10 - 15 * t + 6 * t * t)


@dataclass(frozen=True)
class Segment:
    """Move the tcp to ``pos``/``rot`` in ``steps`` control steps with the gripper at ``gripper``."""

    pos: np.ndarray
    rot: np.ndarray | None
    gripper: float
    steps: int


class WaypointFollower:
    """Turns a list of segments into one action per control step."""

    def __init__(self, world: World, segments: list[Segment]) -> None:
        self.world = world
        self.ik = DifferentialIK(world)
        self.segments = segments
        self.index = 0
        self.step = 0
        self.q = world.arm_qpos()
        self.start_pos, self.start_rot = world.tcp_position(), world.tcp_rotation()

    @property
    def done(self) -> bool:
        return self.index >= len(self.segments)

    def act(self) -> np.ndarray:
        if self.done:
            last = self.segments[-1] if self.segments else None
            return np.append(self.q, last.gripper if last else 1.0)
        seg = self.segments[self.index]
        self.step += 1
        t = min_jerk(min(1.0, self.step / max(1, seg.steps)))
        pos = (1 - t) * self.start_pos + t * seg.pos
        rot = None if seg.rot is None else slerp_rot(self.start_rot, seg.rot, t)
        self.q = self.ik.solve(pos, rot, q_start=self.q, iterations=20).qpos
        action = np.append(self.q, seg.gripper)
        if self.step >= seg.steps:
            self.start_pos = seg.pos
            self.start_rot = seg.rot if seg.rot is not None else self.start_rot
            self.index += 1
            self.step = 0
        return action
