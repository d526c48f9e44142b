"""Reach: whether and how the arm gets the hand to a pose, touching nothing it should not.

Dry runs of the IK from the hand's planned joints (:class:`~pipette_cli.skills.hand.Hand`), along a
straight tool line or through joint space, with the arm's collisions checked against the scene
(what the hand holds or may touch excepted). The transit planner (:mod:`.transit`) builds paths on
these; the skill context (:mod:`.runtime`) checks every move it plans with them.
"""

from __future__ import annotations

from collections.abc import Set as AbstractSet

import numpy as np

from pipette_cli.sim.world import World
from pipette_cli.skills.frames import rotation_angle, slerp
from pipette_cli.skills.hand import Hand
from pipette_cli.skills.ik import ArmIK, IKSolution
from pipette_cli.skills.moves import APPROACH_SPEED, EASY_TRAVEL, FLIP, MAX_SWING, Leg

NEAR_HALF_TURN = np.deg2rad(175.0)
"""A turn this close to half a turn has no clear shorter arc (its direction is decided by rounding:
a parallel gripper's flip is exactly half a turn): no straight tool line makes it."""
MAX_SAG = 0.02
"""Metres a held object may dip below both ends of a move through joint space (the carrying height
over what stands between was planned for the ends: a pipette turned upright on a sagging arc struck
the stand it was carried over)."""


class Reach:
    """IK dry runs and collision checks from the hand's planned state (see the module docstring)."""

    def __init__(self, world: World, ik: ArmIK, hand: Hand) -> None:
        self.world = world
        self.ik = ik
        self.hand = hand
        self._solved: dict[tuple, np.ndarray] = {}

    def reachable(self, pos: np.ndarray, rot: np.ndarray, *, yaw_free: bool = False) -> bool:
        """Whether the arm reaches ``pos``/``rot`` (or its flip, with an empty hand) from the hand's joints."""
        return self.solve_flip(pos, rot, self.hand.q, yaw_free=yaw_free)[1].ok()

    def solve(self, pos: np.ndarray, rot: np.ndarray, q: np.ndarray, *, yaw_free: bool = False) -> IKSolution:
        """A careful IK solve from ``q``; where that gets stuck, from the joints a dry run found for this
        pose earlier (so a plan found while choosing between candidates is the one executed)."""
        solution = self.ik.reachable(pos, rot, q, yaw_free=yaw_free)
        key = _pose_key(pos, rot)
        if solution.ok():
            self._solved[key] = solution.qpos
            return solution
        hint = self._solved.get(key)
        if hint is not None:
            again = self.ik.reachable(pos, rot, hint, yaw_free=yaw_free)
            if again.ok():
                return again
        return solution

    def solve_flip(
        self, pos: np.ndarray, rot: np.ndarray, q: np.ndarray, *, yaw_free: bool = False, best: bool = False
    ) -> tuple[np.ndarray, IKSolution]:
        """Solve for ``rot`` and (empty hand) its half-turn flip; keep the solution whose joints move
        least from ``q`` among those that reach the pose. With ``best`` (a move through free space) each
        is the most comfortable arm configuration for the pose, not the nearest."""
        options = [rot] if self.hand.held is not None else [rot, rot @ FLIP]
        best_found = None
        for option in options:
            solution = self.ik.best(pos, option, q) if best else self.solve(pos, option, q, yaw_free=yaw_free)
            cost = float(np.sum(np.abs(solution.qpos - q))) + (0.0 if solution.ok() else 1e3)
            if best_found is None or cost < best_found[0]:
                best_found = (cost, option, solution)
            if cost < EASY_TRAVEL:
                break  # close enough to where the arm is: the flip cannot be much better
        assert best_found is not None
        return best_found[1], best_found[2]

    def straight_line(
        self, start: Leg, point: np.ndarray, rot: np.ndarray, tolerance: float, room: float = 0.0
    ) -> np.ndarray | None:
        """Joints at ``point``/``rot`` reached along a straight tool line from ``start`` (the way a straight
        move is executed), checked for reach and collisions (keeping ``room`` metres) every 2 cm and every
        8 degrees of turn (a big turn on a short line is where the warm-started IK can wander off);
        ``None`` if it fails, or if it would turn the hand about half a turn (:data:`NEAR_HALF_TURN`)."""
        point = np.asarray(point, float)
        turn = rotation_angle(start.rot, rot)
        if turn > NEAR_HALF_TURN:
            return None
        steps = max(float(np.linalg.norm(point - start.pos)) / 0.02, turn / np.deg2rad(8.0))
        n = max(2, int(np.ceil(steps)) + 1)
        q = start.q
        for t in np.linspace(0.0, 1.0, n)[1:]:
            p = (1 - t) * start.pos + t * point
            r = slerp(start.rot, rot, t)
            solution = self.ik.solve(p, r, q, iterations=15, dt=0.1, careful=True)
            if not solution.ok(max(tolerance, 0.006)) or self.hits(solution.qpos, room):
                return None
            q = solution.qpos
        final = self.ik.reachable(point, rot, q)
        return final.qpos if final.ok(tolerance) else None

    def obstacle(self, q0: np.ndarray, q1: np.ndarray) -> str:
        """Names of what the arm touches on the way from ``q0`` to ``q1`` (for messages)."""
        m = self.world.model
        for t in np.linspace(0.0, 1.0, 12)[1:]:
            hits = self.hits((1 - t) * q0 + t * q1)
            if hits:
                robot, other = hits[0]
                return f"hit {m.body(other).name} with its {m.body(robot).name.removeprefix('robot/')}"
        held = self.hand.held
        return f"swing {held.name!r} round on the way" if held else "leave its path"

    def hits(self, q: np.ndarray, room: float = 0.0) -> list[tuple[int, int]]:
        """What the arm touches (or comes within ``room`` metres of) at joints ``q``, besides what the
        hand may touch (:attr:`Hand.allowed`) and what it carries (which moves with it): ``(robot
        body, other body)`` pairs."""
        return self.ik.collisions(q, self.hand.allowed, self.hand.held_bodies(), room)

    def clear_path(self, q0: np.ndarray, q1: np.ndarray, samples: int | None = None, room: float = 0.0) -> bool:
        """Whether the arm moves from joints ``q0`` to ``q1`` (interpolated) without touching the
        scene: anything but what the hand holds or is about to touch (:attr:`Hand.allowed`). With
        ``room``, it keeps that many metres from the scene on the way, less over the last quarter
        (where the move slows down onto its end, which may be close to something)."""
        if samples is None:  # a sample every 0.08 rad of the joint that moves most
            samples = max(4, int(np.ceil(float(np.max(np.abs(q1 - q0))) / 0.08)) + 1)
        ends = None
        if self.hand.held is not None:  # a held object must not be swung round, nor dipped, on the way
            (p0, r0), (p1, r1) = self.ik.tool_pose(q0), self.ik.tool_pose(q1)
            ends = (r0, r1, min(p0[2], p1[2]) - MAX_SAG)
        for t in np.linspace(0.0, 1.0, samples)[1:]:
            q = (1 - t) * q0 + t * q1
            if self.hits(q, room * min(1.0, 4.0 * (1.0 - t))):
                return False
            if ends is not None:
                pos, rot = self.ik.tool_pose(q)
                if rotation_angle(rot, slerp(ends[0], ends[1], t)) > MAX_SWING or pos[2] < ends[2]:
                    return False
        return True

    def nearest_flip(self, rot: np.ndarray, reference: np.ndarray | None = None) -> np.ndarray:
        """A parallel gripper is the same turned half a turn about its approach axis: of ``rot`` and
        its flip, the one nearer ``reference`` (the hand's planned rotation by default; an empty hand
        only: a held object turns with the hand)."""
        if self.hand.held is not None:
            return rot
        flipped = rot @ FLIP
        ref = self.hand.rot if reference is None else reference
        return flipped if rotation_angle(ref, flipped) < rotation_angle(ref, rot) - 1e-6 else rot

    def margin(
        self,
        poses: list[tuple[np.ndarray, np.ndarray]],
        touch: AbstractSet[int] = frozenset(),
        start: Leg | None = None,
        collisions: bool = True,
    ) -> float | None:
        """How comfortably the arm reaches every pose in turn (radians to the nearest joint limit,
        the least over the poses), or ``None`` when one is out of reach or the arm would touch
        something on the way other than ``touch`` (and what it holds or may touch anyway). From
        ``start`` (where a transit ends), each pose is reached along a straight tool line, as it will be."""
        low, high = self.world.arm_range[:, 0], self.world.arm_range[:, 1]
        worst = np.inf
        with self.hand.touching(set(touch)):
            leg = start
            for pos, rot in poses:
                if leg is None:
                    rot, solution = self.solve_flip(pos, rot, self.hand.q)
                    if not solution.ok() or (collisions and self.hits(solution.qpos)):
                        return None
                    q = solution.qpos
                else:
                    if self.hand.held is None:
                        rot = self.nearest_flip(rot, leg.rot)
                    line = self.straight_line(leg, pos, rot, 0.004)
                    if line is None:
                        return None
                    q = line
                leg = Leg(np.asarray(pos, float), rot, q, APPROACH_SPEED)
                worst = min(worst, float(np.min(np.minimum(q - low, high - q))))
        return worst


def _pose_key(pos: np.ndarray, rot: np.ndarray) -> tuple:
    return tuple(np.round(np.asarray(pos, float), 3)) + tuple(np.round(np.asarray(rot, float), 2).flatten())
