"""The skill runtime: a skill is a generator of tool moves, planned against the world it reads.

A skill function takes a :class:`SkillContext` and its step spec and yields :class:`Move` s. The
program runner (:mod:`.program`) executes each move before asking the generator for the next,
so code after a ``yield`` sees the world as the move left it: a skill measures where the object
really sits in the hand after closing, checks that a lid really moved, and plans the next motion
from there. Every move's end pose is checked for reachability when it is planned (a dry run of
the IK); a skill that cannot do its job raises :class:`SkillFailure` with a one-line reason.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from collections.abc import Set as AbstractSet
from contextlib import contextmanager
from typing import Any

import mujoco
import numpy as np

from pipette_cli.plugins import Plugins
from pipette_cli.sim.world import World
from pipette_cli.skills import transit
from pipette_cli.skills.frames import rotation_angle, slerp
from pipette_cli.skills.ik import ArmIK, IKSolution
from pipette_cli.skills.moves import (  # re-exported: skills import them from here
    APPROACH_SPEED,
    CLOSED,
    COMFORT,
    COVER_ROOM,
    EASY_TRAVEL,
    ENOUGH,
    FLIP,
    FREE_TOLERANCE,
    HELD_SPEED,
    MAX_SWING,
    MIN_SECONDS,
    OPEN,
    TRANSIT_SPEED,
    TURN_SPEED,
    Held,
    Leg,
    Move,
    SkillFailure,
    fmt,
)
from pipette_cli.skills.scene import SceneQuery
from pipette_cli.specs.expert import SKILLS, StepSpec

log = logging.getLogger(__name__)

Skill = Callable[["SkillContext", Any], Iterator[Move]]


MIN_JERK_PEAK = 1.875
"""Peak over mean speed of a minimum-jerk move (how moves are interpolated)."""
MAX_SAG = 0.02
"""Metres a held object may dip below both ends of a move through joint space (the carrying height
over what stands between was planned for the ends: a pipette turned upright on a sagging arc struck
the stand it was carried over)."""
JOINT_SPEED_SHARE = 0.7
"""Share of a joint's top speed a move may ask of it (the rest is for gravity and acceleration)."""


def joint_speeds(world: World) -> np.ndarray:
    """The speed (rad/s) each arm joint's actuator can drive it at: its force limit over the joint's
    damping (the terminal speed at full force), times :data:`JOINT_SPEED_SHARE`; unbounded where the
    joint has no damping or its actuator no force limit. A move timed only by the tool's speed can
    ask a strongly damped wrist (the UR5e's) for more than it can give, and the arm lags its plan."""
    m = world.model
    out = np.full(len(world.arm_joint_ids), np.inf)
    for i, joint in enumerate(world.arm_joint_ids):
        damping = float(m.dof_damping[m.jnt_dofadr[joint]])
        for a in range(m.nu):
            joint_driven = m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and m.actuator_trnid[a, 0] == joint
            if joint_driven and m.actuator_forcelimited[a] and damping > 0:
                out[i] = JOINT_SPEED_SHARE * float(m.actuator_forcerange[a, 1]) / damping
    return out


class SkillContext:
    """What skills share during one episode: the world, the robot's facts, IK, scene queries, the
    planned tool state after the last move, and what is in the hand."""

    def __init__(self, world: World, rng: np.random.Generator) -> None:
        self.world = world
        self.robot = world.robot
        self.rng = rng
        self.ik = ArmIK(world)
        self.scene = SceneQuery(world)
        self.pos = world.tcp_position()
        self.rot = world.tcp_rotation()
        self.q = world.arm_qpos()
        self.gripper = OPEN if world.task.embodiment.gripper == "open" else CLOSED
        self.held: Held | None = None
        self._solved: dict[tuple, np.ndarray] = {}
        self.allowed: set[int] = set()
        """Bodies the hand may touch while moving through free space (set by a skill around a contact)."""
        self.next_step: Any = None
        """The program's step after the running one (a pick looks ahead to where the object goes)."""
        self.start = {name: world.position(name) for name in world.objects}
        self.base = np.asarray(world.task.embodiment.base.pos, dtype=float)
        self.joint_speed = joint_speeds(world)

    # ------------------------------------------------------------------ moves
    def move(
        self,
        pos: np.ndarray,
        rot: np.ndarray | None = None,
        *,
        gripper: float | None = None,
        speed: float = TRANSIT_SPEED,
        seconds: float | None = None,
        yaw_free: bool = False,
        what: str = "the tool pose",
        check: bool = True,
    ) -> Move:
        """Plan a move of the tcp to ``pos``/``rot``: at transit speed through free space (joints
        interpolated; the end pose may be missed by :data:`FREE_TOLERANCE`), slower along a straight
        tool line; ``seconds``, where given, is the least it takes. Raises :class:`SkillFailure` when
        the end pose is out of reach."""
        pos = np.asarray(pos, dtype=float)
        free = speed >= TRANSIT_SPEED
        if rot is None:
            rot = self.rot
        elif not free:  # a straight line keeps the hand's side: the flip nearest the current rotation
            rot = self.nearest_flip(np.asarray(rot, dtype=float))
        if not free and check and not yaw_free:  # followed as a straight tool line: check it that way
            reached = self.straight_line(Leg(self.pos, self.rot, self.q, speed), pos, rot, 0.004)
            if reached is not None:
                solution = IKSolution(reached, 0.0, 0.0)
            else:
                solution = self.solve(pos, rot, self.q)
                if solution.ok():
                    raise SkillFailure(
                        f"{what} {fmt(pos)}: no straight way there for the {self.robot.name} "
                        "that touches nothing but what it works on"
                    )
        elif rot is self.rot:
            solution = self.solve(pos, rot, self.q, yaw_free=yaw_free)
        else:
            rot, solution = self.solve_flip(pos, np.asarray(rot, dtype=float), self.q, yaw_free=yaw_free)
        if not solution.ok(FREE_TOLERANCE if free else 0.004):
            distance = float(np.linalg.norm(pos[:2] - self.base[:2]))
            raise SkillFailure(
                f"{what} {fmt(pos)} is out of reach for the {self.robot.name} "
                f"({distance:.2f} m from its base, reach {self.robot.reach:.2f} m; "
                f"IK misses by {solution.position_error * 1000:.0f} mm, "
                f"{np.rad2deg(solution.rotation_error):.0f} deg)"
            )
        if check and free and not self.clear_path(self.q, solution.qpos):
            raise SkillFailure(f"{what} {fmt(pos)}: the {self.robot.name} would {self.obstacle(self.q, solution.qpos)}")
        if yaw_free or free:
            pos, rot = self.ik.tool_pose(solution.qpos)
        seconds = max(seconds or 0.0, self._seconds(pos, rot, speed, solution.qpos))
        self.pos, self.rot, self.q = pos, rot, solution.qpos
        if gripper is not None:
            self.gripper = gripper
        return Move(pos, rot, self.gripper, float(seconds), solution.qpos, free=free)

    def planned(
        self,
        pos: np.ndarray,
        rot: np.ndarray,
        q: np.ndarray,
        *,
        speed: float,
        straight: bool = False,
        joints: bool = False,
    ) -> Move:
        """A move to a pose whose joints ``q`` were already planned (and checked) by :meth:`transit`:
        through joint space at transit speed or where ``joints`` says so, else along a straight line."""
        free = (speed >= TRANSIT_SPEED or joints) and not straight
        if free:  # through joint space the tool ends where the joints put it (within the free tolerance)
            pos, rot = self.ik.tool_pose(q)
        seconds = self._seconds(pos, rot, speed, q)
        self.pos, self.rot, self.q = np.asarray(pos, float), rot, q
        return Move(self.pos, rot, self.gripper, seconds, q, free=free)

    def _seconds(self, pos: np.ndarray, rot: np.ndarray, speed: float, q: np.ndarray | None = None) -> float:
        """Duration of a move from the planned pose: its length at ``speed`` (at most
        :data:`HELD_SPEED` with something in the hand), its turn, or the time the slowest joint needs
        to reach ``q`` at the peak of the minimum-jerk profile, whichever takes longest. The joints
        bound a straight move too: a quarter turn of the hand can be most of a turn of a wrist joint
        (the UR5e's, damped to under 1 rad/s), which then lags the line and drags the tool off it."""
        if self.held is not None:
            speed = min(speed, HELD_SPEED)
        joints = 0.0 if q is None else MIN_JERK_PEAK * float(np.max(np.abs(np.asarray(q) - self.q) / self.joint_speed))
        return max(
            MIN_SECONDS,
            float(np.linalg.norm(np.asarray(pos) - self.pos)) / speed,
            rotation_angle(self.rot, rot) / TURN_SPEED,
            joints,
        )

    def grip(self, gripper: float, seconds: float = 0.5) -> Move:
        """Open (1) or close (0) the gripper where the tool stands."""
        self.gripper = gripper
        return Move(self.pos, self.rot, gripper, seconds, self.q)

    def hold(self, seconds: float) -> Move:
        return Move(self.pos, self.rot, self.gripper, max(seconds, self.world.control_dt), self.q)

    def reachable(self, pos: np.ndarray, rot: np.ndarray, *, yaw_free: bool = False) -> bool:
        return self.solve_flip(pos, rot, self.q, yaw_free=yaw_free)[1].ok()

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
    ) -> tuple[np.ndarray, Any]:
        """Solve for ``rot`` and (empty hand) its half-turn flip; keep the solution whose joints move
        least from ``q`` among those that reach the pose. With ``best`` (a move through free space) each
        is the most comfortable arm configuration for the pose, not the nearest."""
        options = [rot] if self.held is not None else [rot, rot @ FLIP]
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

    def straight_line(self, start: Leg, point: np.ndarray, rot: np.ndarray, tolerance: float) -> np.ndarray | None:
        """Joints at ``point``/``rot`` reached along a straight tool line from ``start`` (the way a straight
        move is executed), checked for reach and collisions every 2 cm and every 8 degrees of turn (a
        big turn on a short line is where the warm-started IK can wander off); ``None`` if it fails."""
        point = np.asarray(point, float)
        steps = max(float(np.linalg.norm(point - start.pos)) / 0.02, rotation_angle(start.rot, rot) / np.deg2rad(8.0))
        n = max(2, int(np.ceil(steps)) + 1)
        q = start.q
        for t in np.linspace(0.0, 1.0, n)[1:]:
            p = (1 - t) * start.pos + t * point
            r = slerp(start.rot, rot, t)
            solution = self.ik.solve(p, r, q, iterations=15, dt=0.1, careful=True)
            if not solution.ok(max(tolerance, 0.006)) or self.hits(solution.qpos):
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
        return f"swing {self.held.name!r} round on the way" if self.held else "leave its path"

    def hits(self, q: np.ndarray, room: float = 0.0) -> list[tuple[int, int]]:
        """What the arm touches (or comes within ``room`` metres of) at joints ``q``, besides what the
        hand may touch (:attr:`allowed`) and what it carries (which moves with it): ``(robot body,
        other body)`` pairs."""
        return self.ik.collisions(q, self.allowed, self.held_bodies(), room)

    @contextmanager
    def touching(self, bodies: set[int]) -> Iterator[None]:
        """Allow the hand to touch ``bodies`` (what it grasps, pushes or presses) inside the block."""
        before = self.allowed
        self.allowed = before | set(bodies)
        try:
            yield
        finally:
            self.allowed = before

    def clear_path(self, q0: np.ndarray, q1: np.ndarray, samples: int | None = None, room: float = 0.0) -> bool:
        """Whether the arm moves from joints ``q0`` to ``q1`` (interpolated) without touching the
        scene: anything but what the hand holds or is about to touch (:attr:`allowed`). With
        ``room``, it keeps that many metres from the scene on the way, less over the last quarter
        (where the move slows down onto its end, which may be close to something)."""
        if samples is None:  # a sample every 0.08 rad of the joint that moves most
            samples = max(4, int(np.ceil(float(np.max(np.abs(q1 - q0))) / 0.08)) + 1)
        ends = None
        if self.held is not None:  # a held object must not be swung round, nor dipped, on the way
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
        its flip, the one nearer the current tool rotation (an empty hand only: a held object turns
        with the hand)."""
        if self.held is not None:
            return rot
        flipped = rot @ FLIP
        ref = self.rot if reference is None else reference
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
        before = self.allowed
        self.allowed = before | set(touch)
        try:
            leg = start
            for pos, rot in poses:
                if leg is None:
                    rot, solution = self.solve_flip(pos, rot, self.q)
                    if not solution.ok() or (collisions and self.hits(solution.qpos)):
                        return None
                    q = solution.qpos
                else:
                    if self.held is None:
                        rot = self.nearest_flip(rot, leg.rot)
                    q = self.straight_line(leg, pos, rot, 0.004)
                    if q is None:
                        return None
                leg = Leg(np.asarray(pos, float), rot, q, APPROACH_SPEED)
                worst = min(worst, float(np.min(np.minimum(q - low, high - q))))
        finally:
            self.allowed = before
        return worst

    def choose(
        self,
        candidates: list[Any],
        poses: Callable[[Any], list[tuple[np.ndarray, np.ndarray]]],
        comfortable: float = COMFORT,
        via: Callable[[Any], tuple[Any, ...]] | None = None,
        touch: AbstractSet[int] = frozenset(),
    ) -> Any | None:
        """The first candidate whose poses the arm reaches with ``comfortable`` radians to spare at
        every joint, else the one with the most to spare; ``None`` when none is reachable. The poses
        may touch ``touch`` (the part being pushed or pressed). With ``via``, the hand first goes to the
        pose ``via`` gives (a transit that touches nothing; a third item names bodies the transit ignores)
        and from there to each pose in a straight line."""
        best, best_margin = None, -np.inf
        feasible = 0
        for candidate in candidates:
            # cheap first: each pose on its own (reach only, when the path is checked next)
            margin = self.margin(poses(candidate), touch, collisions=via is None)
            if margin is None:
                continue
            if via is not None:
                target = via(candidate)
                legs = self.plan_transit(target[0], target[1], exclude=target[2] if len(target) > 2 else frozenset())
                if legs is None:
                    continue
                start = legs[-1] if legs else Leg(self.pos, self.rot, self.q, APPROACH_SPEED)
                margin = self.margin(poses(candidate), touch, start)
                if margin is None:
                    continue
            if margin >= comfortable:
                return candidate
            feasible += 1
            if margin > best_margin:
                best, best_margin = candidate, margin
            if feasible >= ENOUGH:
                break  # a few feasible ones, none comfortable: the best of them will do
        return best

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
        fingertip = 0.012
        if self.held is None:
            return fingertip
        shape = self.scene.shape(self.held.name)
        return max(fingertip, float(self.pos[2] - shape.bottom + 0.0))

    def hang_at(self, rot: np.ndarray) -> float:
        """How far below the tcp the hand and what it holds would reach with the tool turned to ``rot``
        (what it holds keeping its place in the hand)."""
        fingertip = 0.012
        if self.held is None:
            return fingertip
        shape = self.scene.shape(self.held.name)
        center = shape.axes.T @ (shape.center - self.world.position(self.held.name))  # in the object's frame
        turned = rot @ self.held.rot
        lowest = (rot @ self.held.pos)[2] + (turned @ center)[2] - np.abs(turned[2]) @ shape.half
        return max(fingertip, float(-lowest))

    def held_bodies(self) -> set[int]:
        return self.scene.bodies(self.held.name) if self.held else set()

    # ------------------------------------------------------------------ paths (skills/transit.py)
    def transit(
        self,
        pos: np.ndarray,
        rot: np.ndarray,
        *,
        exclude: AbstractSet[int] = frozenset(),
        radius: float = 0.04,
        what: str = "the approach",
    ) -> Iterator[Move]:
        """Go to ``pos``/``rot`` over whatever stands in between (see :meth:`plan_transit`)."""
        return transit.transit(self, pos, rot, exclude=exclude, radius=radius, what=what)

    def can_reach(self, pos: np.ndarray, rot: np.ndarray, exclude: AbstractSet[int] = frozenset()) -> bool:
        """Whether :meth:`transit` finds a path from the hand to ``pos``/``rot``."""
        return transit.can_reach(self, pos, rot, exclude)

    def plan_transit(
        self, pos: np.ndarray, rot: np.ndarray, *, exclude: AbstractSet[int] = frozenset(), radius: float = 0.04
    ) -> list[Leg] | None:
        """The legs from the hand to ``pos``/``rot``, each reached by the arm without touching anything ..."""
        return transit.plan_transit(self, pos, rot, exclude=exclude, radius=radius)

    def covered(self, point: np.ndarray, exclude: set[int], room: float = COVER_ROOM) -> bool:
        """Whether something overhead (a shelf, a roof) is within ``room`` metres above ``point``."""
        return transit.covered(self, point, exclude, room)

    def leave_enclosure(self, exclude: set[int]) -> Iterator[Move]:
        """Back the hand (and what it holds) out of whatever covers it, level, toward the robot."""
        return transit.leave_enclosure(self, exclude)

    def lift_clear(
        self, height: float, exclude: AbstractSet[int] = frozenset(), *, required: bool = False
    ) -> Iterator[Move]:
        """Lift by ``height``: less where something is overhead or the arm cannot go higher (unless ..."""
        return transit.lift_clear(self, height, exclude, required=required)

    def withdraw(self, distance: float) -> Iterator[Move]:
        """Move the empty hand back along its approach axis by up to ``distance`` (less where the arm cannot)."""
        return transit.withdraw(self, distance)


SKILL_RUNTIMES: Plugins[Skill] = Plugins("skill", SkillFailure)


def skill(spec: type[StepSpec]) -> Callable[[Skill], Skill]:
    """Register the runtime of the skill step ``spec`` (registered in :mod:`pipette_cli.specs.expert`) by its name."""
    return SKILL_RUNTIMES.register(SKILLS.name_of(spec))


def _pose_key(pos: np.ndarray, rot: np.ndarray) -> tuple:
    return tuple(np.round(np.asarray(pos, float), 3)) + tuple(np.round(np.asarray(rot, float), 2).flatten())
