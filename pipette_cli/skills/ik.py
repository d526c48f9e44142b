"""Inverse kinematics for skills, with mink: the tool pose as a frame task, a light posture task
toward the robot's home configuration, and the joint limits as constraints.

Teleoperation keeps the paper's damped-least-squares solver (:mod:`pipette_cli.sim.controllers`);
skills need more than it gives: joint limits respected as constraints rather than clipped (a
clipped solution drifts off the straight line), a posture that keeps a 7-joint arm's elbow where
it belongs over long programs, and per-axis orientation costs (a tube's grasp is free about the
tube's axis). mink solves these as one small quadratic program per iteration.

It works on a scratch copy of the world's state, so the simulation is never disturbed; only the
arm's joints move (every other degree of freedom has no cost but damping and stays put).
"""

from __future__ import annotations

import copy
from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from functools import cached_property

import mink
import mujoco
import numpy as np
from mink.utils import get_subtree_body_ids

from pipette_cli.sim.scene import ROBOT_PREFIX
from pipette_cli.sim.world import World

POSTURE_COST = 1e-2
DAMPING = 1e-3
SOLVER = "daqp"
CONVERGED = 2e-4
"""Metres (and tenths of a radian) of tool error at which a careful solve stops early."""
COMFORTABLE = 0.3
"""Radians from every joint limit at which the nearest solution is kept without trying the seeds."""
HOPELESS = 0.05
"""Metres of tool error after 25 iterations at which a careful solve gives up."""
ROOM_SEEN = 0.02
"""Metres from the scene within which the arm's contacts are reported (the most room a caller asks for)."""


@dataclass(frozen=True)
class IKSolution:
    qpos: np.ndarray
    position_error: float
    rotation_error: float

    def ok(self, position_tol: float = 0.004, rotation_tol: float = 0.05) -> bool:
        return self.position_error <= position_tol and self.rotation_error <= rotation_tol


class ArmIK:
    """Tool-pose IK for one world's arm (see the module docstring)."""

    def __init__(self, world: World) -> None:
        self.world = world
        # a copy whose robot geoms report contacts ROOM_SEEN early, so a dry run can ask for room
        # around the arm; the world's own model (and its physics) stays as it is
        model = copy.copy(world.model)
        self.robot_bodies = {b for b in range(model.nbody) if model.body(b).name.startswith(ROBOT_PREFIX)}
        robot_geoms = np.isin(model.geom_bodyid, list(self.robot_bodies))
        model.geom_margin[robot_geoms] = np.maximum(model.geom_margin[robot_geoms], ROOM_SEEN)
        self.configuration = mink.Configuration(model, world.data.qpos.copy())
        self.tool = mink.FrameTask(
            ROBOT_PREFIX + "tcp", "site", position_cost=1.0, orientation_cost=1.0, lm_damping=1e-6
        )
        self.posture = mink.PostureTask(model, cost=POSTURE_COST)
        self.distal, self.proximal = _arm_halves(world)
        ee = model.body(ROBOT_PREFIX + world.robot.end_effector.body).id
        self.hand_bodies = set(get_subtree_body_ids(model, ee)) & self.robot_bodies
        self.limits: list[mink.Limit] = [mink.ConfigurationLimit(model)]
        if self.distal and self.proximal:
            self.limits.append(
                mink.CollisionAvoidanceLimit(
                    model,
                    geom_pairs=[(self.distal, self.proximal)],
                    minimum_distance_from_collisions=0.005,
                    collision_detection_distance=0.05,
                )
            )
        self._adr = world.arm_qpos_adr
        home = world.data.qpos.copy()
        home[self._adr] = world.robot.home()
        self.posture.set_target(home)

    def solve(
        self,
        pos: np.ndarray,
        rot: np.ndarray,
        q_start: np.ndarray,
        *,
        iterations: int = 4,
        yaw_free: bool = False,
        dt: float = 0.05,
        careful: bool = False,
    ) -> IKSolution:
        """Arm joints putting the tcp at ``pos``/``rot``, starting from arm joints ``q_start``.

        ``yaw_free`` leaves the rotation about the tool's approach axis to the posture task. A
        ``careful`` solve (a dry run) stops early once converged or clearly hopeless, and leaves the
        self-collision constraint out (the caller checks the result for collisions instead).
        """
        limits = self.limits[:1] if careful else self.limits
        q = self.world.data.qpos.copy()
        q[self._adr] = np.clip(q_start, self.world.arm_range[:, 0], self.world.arm_range[:, 1])
        self.configuration.update(q)
        self.tool.set_orientation_cost(np.array([1.0, 1.0, 0.02 if yaw_free else 1.0]))
        self.tool.set_target(
            mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rot), np.asarray(pos, dtype=float))
        )
        for k in range(iterations):
            velocity = mink.solve_ik(self.configuration, [self.tool, self.posture], dt, SOLVER, DAMPING, limits=limits)
            self.configuration.integrate_inplace(velocity, dt)
            if careful and k % 5 == 4 and k + 1 < iterations:
                error = self.tool.compute_error(self.configuration)
                pos_err = float(np.linalg.norm(error[:3]))
                if pos_err < CONVERGED and np.linalg.norm(error[3:] if not yaw_free else error[3:5]) < 10 * CONVERGED:
                    break
                if k >= 24 and pos_err > HOPELESS:
                    break
        error = self.tool.compute_error(self.configuration)
        rot_err = float(np.linalg.norm(error[3:] if not yaw_free else error[3:5]))
        return IKSolution(self.configuration.q[self._adr].copy(), float(np.linalg.norm(error[:3])), rot_err)

    @cached_property
    def seeds(self) -> list[np.ndarray]:
        """Arm configurations a stuck solve restarts from: home (hand down) and the hand pointing
        forward level and pitched, in front of the robot (found once per world from home)."""
        w = self.world
        home = w.robot.home()
        base = np.asarray(w.task.embodiment.base.pos, dtype=float)
        out = [home]
        for pitch, height in ((0.0, 0.15), (45.0, 0.2)):
            th = np.deg2rad(pitch)
            approach = np.array([np.cos(th), 0.0, -np.sin(th)])
            y = np.array([0.0, 1.0, 0.0])
            rot = np.column_stack([np.cross(y, approach), y, approach])
            target = base + np.array([0.55 * w.robot.reach, 0.0, height])
            solution = self.solve(target, rot, home, iterations=120, dt=0.1, careful=True)
            if solution.ok(0.01, 0.1):
                out.append(solution.qpos)
        return out

    def reachable(self, pos: np.ndarray, rot: np.ndarray, q_start: np.ndarray, *, yaw_free: bool = False) -> IKSolution:
        """A careful solve (many iterations) to decide whether a pose can be reached at all: from
        ``q_start``, and again from the robot's home configuration when that gets stuck."""
        first = self.solve(pos, rot, q_start, iterations=60, yaw_free=yaw_free, dt=0.1, careful=True)
        if first.ok():
            return first
        for seed in self.seeds:
            again = self.solve(pos, rot, seed, iterations=40, yaw_free=yaw_free, dt=0.1, careful=True)
            if again.ok():
                return again
        return first

    def best(self, pos: np.ndarray, rot: np.ndarray, q_start: np.ndarray, tolerance: float = 0.004) -> IKSolution:
        """Of the solutions from ``q_start`` and from every seed, the one with the most room to its
        joint limits (a free move may change arm configuration; a straight move cannot)."""
        low, high = self.world.arm_range[:, 0], self.world.arm_range[:, 1]
        found: list[tuple[float, IKSolution]] = []
        for seed in (q_start, *self.seeds):
            solution = self.solve(pos, rot, seed, iterations=60, dt=0.1, careful=True)
            if solution.ok(tolerance):
                margin = float(np.min(np.minimum(solution.qpos - low, high - solution.qpos)))
                if seed is q_start and margin >= COMFORTABLE:
                    return solution  # the nearest solution is comfortable: no need to look further
                found.append((margin - 0.05 * float(np.max(np.abs(solution.qpos - q_start))), solution))
        if not found:
            return self.reachable(pos, rot, q_start)
        return max(found, key=lambda f: f[0])[1]

    def self_collision(self, q_arm: np.ndarray) -> float:
        """Smallest distance (negative: penetration) between the arm's far and near links at ``q_arm``."""
        q = self.world.data.qpos.copy()
        q[self._adr] = q_arm
        self.configuration.update(q)
        data, model = self.configuration.data, self.configuration.model
        best = np.inf
        for g1 in self.distal:
            for g2 in self.proximal:
                best = min(best, mujoco.mj_geomDistance(model, data, g1, g2, 0.05, None))
        return float(best)

    def collisions(
        self,
        q_arm: np.ndarray,
        allow: AbstractSet[int] = frozenset(),
        carried: AbstractSet[int] = frozenset(),
        room: float = 0.0,
    ) -> list[tuple[int, int]]:
        """Robot bodies touching something at ``q_arm`` (the scene as it stands now), as
        ``(robot body, other body)`` pairs. The hand (gripper) touching bodies in ``allow`` (what it
        grasps, pushes or holds) and the fingers touching each other do not count; the arm's links
        touching anything does, except what the hand carries (``carried``): it moves with the hand,
        so where it stands now says nothing about the arm at ``q_arm`` (a wrist lowered onto the
        spot a tall tube occupied before it was carried down). With ``room`` (metres, at most
        :data:`ROOM_SEEN`), coming that close to the scene counts as touching."""
        touching, near = -0.0005, min(room, ROOM_SEEN) if room > 0 else -0.0005
        q = self.world.data.qpos.copy()
        q[self._adr] = q_arm
        self.configuration.update(q)
        model, data = self.configuration.model, self.configuration.data
        mujoco.mj_collision(model, data)
        out = []
        for i in range(data.ncon):
            contact = data.contact[i]
            if contact.dist >= near:
                continue
            b1, b2 = int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2])
            r1, r2 = b1 in self.robot_bodies, b2 in self.robot_bodies
            if r1 == r2 and contact.dist >= touching:
                continue  # the room is kept from the scene, not between the arm's own links
            if r1 == r2 and (not r1 or (b1 in self.hand_bodies and b2 in self.hand_bodies)):
                continue  # scene-scene contacts, or the fingers touching each other
            robot, other = (b1, b2) if r1 else (b2, b1)
            if (other in allow and robot in self.hand_bodies) or other in carried:
                continue
            out.append((robot, other))
            self.last_contact = (contact.geom1, contact.geom2, float(contact.dist))
        return out

    def tool_pose(self, q_arm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics: tcp position and rotation for arm joints ``q_arm``."""
        q = self.world.data.qpos.copy()
        q[self._adr] = q_arm
        self.configuration.update(q)
        site = self.configuration.data.site(ROBOT_PREFIX + "tcp")
        return site.xpos.copy(), site.xmat.reshape(3, 3).copy()


def _arm_halves(world: World) -> tuple[list[int], list[int]]:
    """Collision geoms of the arm's far half (the last three arm links and the hand) and near half
    (its base and first two links): the pairs a folding arm can drive into each other."""
    m = world.model
    links = [int(m.jnt_bodyid[j]) for j in world.arm_joint_ids]
    root = int(m.body_parentid[links[0]])

    far = set(get_subtree_body_ids(m, links[-3]))
    near = {root, *links[:2]}

    def geoms(bodies: set[int]) -> list[int]:
        return [
            g
            for g in range(m.ngeom)
            if int(m.geom_bodyid[g]) in bodies and (m.geom_contype[g] or m.geom_conaffinity[g])
        ]

    return geoms(far), geoms(near)
