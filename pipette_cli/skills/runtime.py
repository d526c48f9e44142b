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
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from pipette_cli.errors import PipetteError
from pipette_cli.skills.frames import UP, rotation_angle, slerp
from pipette_cli.skills.ik import ArmIK, IKSolution
from pipette_cli.skills.scene import SceneQuery
from pipette_cli.sim.world import World

log = logging.getLogger(__name__)

OPEN, CLOSED = 1.0, 0.0
TRANSIT_SPEED = 0.30
"""m/s of the tool through free space."""
HELD_SPEED = 0.15
"""m/s at most with an object in the hand (a friction grasp slips when jerked)."""
APPROACH_SPEED = 0.12
"""m/s for the last centimetres toward a grasp or a surface."""
FINE_SPEED = 0.05
"""m/s in contact: inserting, pushing a lid, pressing."""
TURN_SPEED = 1.6
"""rad/s of the tool's rotation."""
MIN_SECONDS = 0.2
MAX_SWING = 0.3
"""Radians a held object may turn away from the straight (slerped) rotation on a joint-space move."""
FREE_TOLERANCE = 0.015
"""Metres a waypoint through free space may be missed by (what matters there is clearance)."""
EASY_TRAVEL = 1.5
"""Radians of summed joint travel below which a solution is taken without trying its flip."""
FLIP = np.diag([-1.0, -1.0, 1.0])
"""Half a turn about the tool's approach axis."""
CLEARANCE = 0.04
"""Metres kept between what the hand carries and the surfaces under its path."""
FINAL_APPROACH = 0.04
"""Metres of the last descent onto a target done as a straight tool line (the rest through free space)."""
HAND_HEIGHT = 0.15
COVER_ROOM = 0.4
"""Metres: something overhead closer than this (a shelf, a roof) means a place is reached level, not from above."""
"""Metres the hand stands above its tcp (pointing down): the band a path must keep free."""
COMFORT = 0.25
ENOUGH = 3
"""Feasible but uncomfortable candidates looked at before taking the best of them."""
"""Radians every arm joint should keep from its limits for a pose to count as comfortable."""


class SkillFailure(PipetteError):
    """A skill cannot do its job here (out of reach, no grasp, a joint that does not move)."""


@dataclass(frozen=True)
class Move:
    """Bring the tcp to ``pos``/``rot`` over ``seconds`` with the gripper at ``gripper`` (1 open)."""

    pos: np.ndarray
    rot: np.ndarray
    gripper: float
    seconds: float
    q: np.ndarray
    """Arm joints that reach the end pose (from the planning dry run)."""
    free: bool = False
    """Through free space: interpolate the joints to ``q`` (the dry run's solution) instead of
    following a straight tool line, so the arm never has to find its way by itself."""


@dataclass(frozen=True)
class Leg:
    """A planned tool pose with the arm joints that reach it, and the speed to get there."""

    pos: np.ndarray
    rot: np.ndarray
    q: np.ndarray
    speed: float
    straight: bool = False
    """Along a straight tool line (IK every control step) rather than through joint space."""


@dataclass(frozen=True)
class Held:
    """An object in the hand: its origin and rotation in the tcp frame, measured after the grasp."""

    name: str
    pos: np.ndarray
    rot: np.ndarray


Skill = Callable[["SkillContext", Any], Iterator[Move]]


def fmt(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in p) + ")"


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

    # ------------------------------------------------------------------ moves
    def move(self, pos: np.ndarray, rot: np.ndarray | None = None, *, gripper: float | None = None,
             speed: float = TRANSIT_SPEED, seconds: float | None = None, yaw_free: bool = False,
             what: str = "the tool pose", check: bool = True) -> Move:
        """Plan a move of the tcp to ``pos``/``rot``: at transit speed through free space (joints
        interpolated; the end pose may be missed by :data:`FREE_TOLERANCE`), slower along a straight
        tool line. Raises :class:`SkillFailure` when the end pose is out of reach."""
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
                    raise SkillFailure(f"{what} {fmt(pos)}: no straight way there for the {self.robot.name} "
                                       "that touches nothing but what it works on")
        elif rot is self.rot:
            solution = self.solve(pos, rot, self.q, yaw_free=yaw_free)
        else:
            rot, solution = self.solve_flip(pos, np.asarray(rot, dtype=float), self.q, yaw_free=yaw_free)
        if not solution.ok(FREE_TOLERANCE if free else 0.004):
            distance = float(np.linalg.norm(pos[:2] - self.base[:2]))
            raise SkillFailure(f"{what} {fmt(pos)} is out of reach for the {self.robot.name} "
                               f"({distance:.2f} m from its base, reach {self.robot.reach:.2f} m; "
                               f"IK misses by {solution.position_error * 1000:.0f} mm, "
                               f"{np.rad2deg(solution.rotation_error):.0f} deg)")
        if check and free and not self.clear_path(self.q, solution.qpos):
            raise SkillFailure(f"{what} {fmt(pos)}: the {self.robot.name} would {self.obstacle(self.q, solution.qpos)}")
        if yaw_free or free:
            pos, rot = self.ik.tool_pose(solution.qpos)
        if seconds is None:
            seconds = self._seconds(pos, rot, speed)
        self.pos, self.rot, self.q = pos, rot, solution.qpos
        if gripper is not None:
            self.gripper = gripper
        return Move(pos, rot, self.gripper, float(seconds), solution.qpos, free=free)

    def planned(self, pos: np.ndarray, rot: np.ndarray, q: np.ndarray, *, speed: float, straight: bool = False) -> Move:
        """A move to a pose whose joints ``q`` were already planned (and checked) by :meth:`transit`."""
        free = speed >= TRANSIT_SPEED and not straight
        if free:  # through joint space the tool ends where the joints put it (within the free tolerance)
            pos, rot = self.ik.tool_pose(q)
        seconds = self._seconds(pos, rot, speed)
        self.pos, self.rot, self.q = np.asarray(pos, float), rot, q
        return Move(self.pos, rot, self.gripper, seconds, q, free=free)

    def _seconds(self, pos: np.ndarray, rot: np.ndarray, speed: float) -> float:
        """Duration of a move from the planned pose: its length at ``speed`` (at most
        :data:`HELD_SPEED` with something in the hand) or its turn, whichever takes longer."""
        if self.held is not None:
            speed = min(speed, HELD_SPEED)
        return max(MIN_SECONDS, float(np.linalg.norm(np.asarray(pos) - self.pos)) / speed,
                   rotation_angle(self.rot, rot) / TURN_SPEED)

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

    def solve_flip(self, pos: np.ndarray, rot: np.ndarray, q: np.ndarray, *, yaw_free: bool = False,
                   best: bool = False) -> tuple[np.ndarray, Any]:
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
        move is executed), checked for reach and collisions every 2 cm; ``None`` if it fails."""
        point = np.asarray(point, float)
        n = max(2, int(np.ceil(float(np.linalg.norm(point - start.pos)) / 0.02)) + 1)
        q = start.q
        for t in np.linspace(0.0, 1.0, n)[1:]:
            p = (1 - t) * start.pos + t * point
            r = slerp(start.rot, rot, t)
            solution = self.ik.solve(p, r, q, iterations=15, dt=0.1, careful=True)
            if not solution.ok(max(tolerance, 0.006)) or self.ik.collisions(solution.qpos, self.allowed | self.held_bodies()):
                return None
            q = solution.qpos
        final = self.ik.reachable(point, rot, q)
        return final.qpos if final.ok(tolerance) else None

    def obstacle(self, q0: np.ndarray, q1: np.ndarray) -> str:
        """Names of what the arm touches on the way from ``q0`` to ``q1`` (for messages)."""
        allow = self.allowed | self.held_bodies()
        m = self.world.model
        for t in np.linspace(0.0, 1.0, 12)[1:]:
            hits = self.ik.collisions((1 - t) * q0 + t * q1, allow)
            if hits:
                robot, other = hits[0]
                return f"hit {m.body(other).name} with its {m.body(robot).name.removeprefix('robot/')}"
        return f"swing {self.held.name!r} round on the way" if self.held else "leave its path"

    @contextmanager
    def touching(self, bodies: set[int]) -> Iterator[None]:
        """Allow the hand to touch ``bodies`` (what it grasps, pushes or presses) inside the block."""
        before = self.allowed
        self.allowed = before | set(bodies)
        try:
            yield
        finally:
            self.allowed = before

    def clear_path(self, q0: np.ndarray, q1: np.ndarray, samples: int | None = None) -> bool:
        """Whether the arm moves from joints ``q0`` to ``q1`` (interpolated) without touching the
        scene: anything but what the hand holds or is about to touch (:attr:`allowed`)."""
        allow = self.allowed | self.held_bodies()
        if samples is None:  # a sample every 0.08 rad of the joint that moves most
            samples = max(4, int(np.ceil(float(np.max(np.abs(q1 - q0))) / 0.08)) + 1)
        r0 = r1 = None
        if self.held is not None:  # a held object must not be swung round on the way
            r0, r1 = self.ik.tool_pose(q0)[1], self.ik.tool_pose(q1)[1]
        for t in np.linspace(0.0, 1.0, samples)[1:]:
            q = (1 - t) * q0 + t * q1
            if self.ik.collisions(q, allow):
                return False
            if r0 is not None and rotation_angle(self.ik.tool_pose(q)[1], slerp(r0, r1, t)) > MAX_SWING:
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

    def margin(self, poses: list[tuple[np.ndarray, np.ndarray]], touch: set[int] = frozenset(),
               start: Leg | None = None, collisions: bool = True) -> float | None:
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
                    if not solution.ok() or (collisions and self.ik.collisions(solution.qpos, self.allowed | self.held_bodies())):
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

    def choose(self, candidates: list[Any], poses: Callable[[Any], list[tuple[np.ndarray, np.ndarray]]],
               comfortable: float = COMFORT, via: Callable[[Any], tuple[Any, ...]] | None = None,
               touch: set[int] = frozenset()) -> Any | None:
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
            raise SkillFailure(f"the grasp on {name!r} did not hold (it is {slip * 1000:.0f} mm from where it was held)")

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

    def held_bodies(self) -> set[int]:
        return self.scene.bodies(self.held.name) if self.held else set()

    # ------------------------------------------------------------------ paths
    def transit(self, pos: np.ndarray, rot: np.ndarray, *, exclude: set[int] = frozenset(), radius: float = 0.04,
                what: str = "the approach") -> Iterator[Move]:
        """Go to ``pos``/``rot`` over whatever stands in between (see :meth:`plan_transit`)."""
        legs = self.plan_transit(pos, rot, exclude=exclude, radius=radius)
        if legs is None:
            raise SkillFailure(f"{what}: no path to {fmt(np.asarray(pos))} within the {self.robot.name}'s reach "
                               "that touches nothing on the way")
        for leg in legs:
            yield self.planned(leg.pos, leg.rot, leg.q, speed=leg.speed, straight=leg.straight)

    def can_reach(self, pos: np.ndarray, rot: np.ndarray, exclude: set[int] = frozenset()) -> bool:
        """Whether :meth:`transit` finds a path from the hand to ``pos``/``rot``."""
        return self.plan_transit(pos, rot, exclude=exclude) is not None

    def plan_transit(self, pos: np.ndarray, rot: np.ndarray, *, exclude: set[int] = frozenset(),
                     radius: float = 0.04) -> list[Leg] | None:
        """The legs from the hand to ``pos``/``rot``, each reached by the arm without touching anything
        (dry run of the IK and of the arm's collisions), or ``None``.

        Out of an enclosure the hand is in, level; then up to a safe height over the corridor (surfaces
        under the path plus what hangs below the hand), across and down, or, when that is out of the
        arm's reach, at the hand's height where it is free or round the side; into a covered
        destination (a shelf under a roof) level through its mouth.
        """
        pos = np.asarray(pos, dtype=float)
        skip = set(exclude) | self.held_bodies()
        hang = self.hang() if self.held else 0.012
        if self.held is not None:
            radius = max(radius, float(np.max(self.scene.shape(self.held.name).world_half()[:2])) + 0.02)
        start = Leg(self.pos, self.rot, self.q, TRANSIT_SPEED)
        legs: list[Leg] = []
        if self.covered(self.pos, skip):
            direction, mouth = self.scene.way_out(self.pos, skip, prefer=self.base - self.pos)
            out = self.pos + direction * (mouth + 0.05)
            out[2] += 0.01
            leg = self._reach(start, out, self.rot, APPROACH_SPEED, 0.004, keep=True)
            if leg is None:
                return None
            legs.append(leg)
            start = leg
        route = [pos]
        if self.covered(pos, skip):
            direction, mouth = self.scene.way_out(pos + 0.01 * UP, skip, prefer=self.base - pos)
            route.insert(0, pos + direction * (mouth + radius + 0.02))
        first = route[0]
        if np.linalg.norm(first[:2] - start.pos[:2]) > 0.01:
            crossing = self._route(start, first, rot, skip, radius, hang, precise=len(route) == 1)
            if crossing is None:
                log.debug("no route to %s", fmt(first))
                return None
            legs += crossing
        else:
            leg = self._reach(start, first, rot, APPROACH_SPEED, 0.004 if len(route) == 1 else FREE_TOLERANCE)
            if leg is None:
                return None
            legs.append(leg)
        for point in route[1:]:  # level through the mouth of the enclosure
            leg = self._reach(legs[-1], point, rot, APPROACH_SPEED, 0.004, keep=True)
            if leg is None:
                log.debug("no way through the mouth to %s", fmt(point))
                return None
            legs.append(leg)
        return legs

    def _reach(self, start: Leg, point: np.ndarray, rot: np.ndarray, speed: float, tolerance: float,
               keep: bool = False) -> Leg | None:
        """The leg from ``start`` to ``point``/``rot`` if the arm reaches it touching nothing: along a
        straight tool line below transit speed (as it will be executed), through joint space above it."""
        if keep:
            rot = start.rot
        if speed < TRANSIT_SPEED:
            if not keep and self.held is None:
                rot = self.nearest_flip(rot, start.rot)
            q = self.straight_line(start, point, rot, tolerance)
            return None if q is None else Leg(np.asarray(point, float), rot, q, speed)
        if keep:
            solution = self.solve(point, rot, start.q)
        else:
            rot, solution = self.solve_flip(point, rot, start.q)
        if solution.ok(tolerance) and self.clear_path(start.q, solution.qpos):
            return Leg(np.asarray(point, float), rot, solution.qpos, speed)
        return None

    def _route(self, start: Leg, goal: np.ndarray, rot: np.ndarray, skip: set[int], radius: float,
               hang: float, precise: bool = True) -> list[Leg] | None:
        """Legs from ``start`` to ``goal``: straight over the top, at the hand's height, or by a detour to
        either side; the first the arm reaches touching nothing."""
        here = start.pos
        heading = goal[:2] - here[:2]
        heading = heading / (np.linalg.norm(heading) + 1e-12)
        side = np.array([-heading[1], heading[0], 0.0])
        here_flat = np.array([here[0], here[1], goal[2]])
        paths: list[tuple[list[np.ndarray], bool | None]] = [([goal], False), ([goal], True), ([goal], None)]
        paths += [([here_flat + s * d * side, goal + s * d * side, goal], True) for d in (0.3, 0.42) for s in (1.0, -1.0)]
        for path, low in paths:
            if low is None:  # straight there, where nothing is in the way (cramped spots near the base)
                points: list[tuple[np.ndarray, bool | None]] | None = [(goal.copy(), True)]
            else:
                points = self._waypoints(here, path, goal, skip, radius, hang, low)
            if points is None:
                continue
            resolved = self._feasible(start, points, rot, precise)
            if resolved is not None:
                return resolved
        return None

    def _waypoints(self, here: np.ndarray, path: list[np.ndarray], goal: np.ndarray, skip: set[int], radius: float,
                   hang: float, low: bool) -> list[tuple[np.ndarray, bool | None]] | None:
        """Climb-and-cross waypoints through ``path`` (and whether each is on the last leg): over everything
        under each leg, or (``low``) at the hand's height where that band is free (under an overhang,
        beside an instrument)."""
        points: list[tuple[np.ndarray, bool | None]] = []
        pos = here.copy()
        for i, end in enumerate(path):
            last = i == len(path) - 1
            floor = goal[2] if last else 0.0
            over = self.scene.corridor_top(pos, end, radius, skip) + CLEARANCE + hang
            z = max(over, floor)
            if low:
                z = max(pos[2], floor)
                under = self.scene.corridor_top(pos, end, radius, skip, below=z + HAND_HEIGHT)
                if under + CLEARANCE + hang > z:  # something in the way at this height: climb over it all
                    z = max(over, z)
            if z > pos[2] + 0.005:
                if self.scene.clearance_above(pos, skip) < z - pos[2] + HAND_HEIGHT:
                    return None  # something overhead: cannot climb here
                points.append((np.array([pos[0], pos[1], z]), False))
            pos = np.array([end[0], end[1], z])
            points.append((pos, last))
        if pos[2] - goal[2] > FINAL_APPROACH + 0.01:
            points.append((goal + FINAL_APPROACH * UP, None))  # the descent: a straight line
            pos = points[-1][0]
        if np.linalg.norm(pos - goal) > 0.003:
            points.append((goal.copy(), True))
        return points

    def _feasible(self, start: Leg, points: list[tuple[np.ndarray, bool | None]], rot: np.ndarray,
                  precise: bool = True) -> list[Leg] | None:
        """Legs through ``points`` when the arm reaches each in turn touching nothing, else ``None``. The
        hand keeps its rotation while climbing and crossing and turns on the last leg; it turns earlier
        where keeping it is out of reach up there, and arrives unturned where turning is."""
        q, current = start.q, start.rot
        out: list[Leg] = []
        turned = False
        for i, (point, last) in enumerate(points):
            final = i == len(points) - 1
            tolerance = 0.004 if precise and final else FREE_TOLERANCE
            if last is None:  # a straight descent onto the goal, turned to its rotation on the way
                target = current if turned else self.nearest_flip(rot, current)
                reached = self.straight_line(Leg(out[-1].pos if out else start.pos, current, q, TRANSIT_SPEED), point, target, tolerance)
                if reached is None:
                    return None
                turned, q, current = True, reached, target
                out.append(Leg(point, target, q, TRANSIT_SPEED, straight=True))
                continue
            if final:  # the goal: in the rotation asked for, whatever happened on the way
                options = [(False, rot)]
            elif turned:
                options = [(True, current)]
            else:
                options = [(False, rot), (True, current)] if last else [(True, current), (False, rot)]
            for keep, target in options:
                if keep:
                    solution = self.solve(point, target, q)
                else:
                    target, solution = self.solve_flip(point, target, q, best=True)
                if solution.ok(tolerance) and self.clear_path(q, solution.qpos):
                    turned = turned or not keep
                    q, current = solution.qpos, target
                    speed = APPROACH_SPEED if final and precise else TRANSIT_SPEED
                    out.append(Leg(point, target, q, speed))
                    break
            else:
                return None
        return out

    def covered(self, point: np.ndarray, exclude: set[int], room: float = COVER_ROOM) -> bool:
        """Whether something overhead (a shelf, a roof) is within ``room`` metres above ``point``."""
        return self.scene.clearance_above(np.asarray(point, float) + 0.01 * UP, exclude) < room

    def leave_enclosure(self, exclude: set[int]) -> Iterator[Move]:
        """Back the hand (and what it holds) out of whatever covers it, level, toward the robot."""
        direction, mouth = self.scene.way_out(self.pos, set(exclude) | self.held_bodies(), prefer=self.base - self.pos)
        start = Leg(self.pos, self.rot, self.q, APPROACH_SPEED)
        for extra in (0.05, 0.03, 0.08):
            out = self.pos + direction * (mouth + extra)
            out[2] += 0.01
            leg = self._reach(start, out, self.rot, APPROACH_SPEED, FREE_TOLERANCE, keep=True)
            if leg is not None:
                yield self.planned(leg.pos, leg.rot, leg.q, speed=APPROACH_SPEED)
                return
        raise SkillFailure(f"no way out of the enclosure from {fmt(self.pos)} that touches nothing")

    def lift_clear(self, height: float, exclude: set[int] = frozenset(), *, required: bool = False) -> Iterator[Move]:
        """Lift by ``height``: less where something is overhead or the arm cannot go higher (unless
        ``required``, when a lift the arm cannot make fails the skill)."""
        room = self.scene.clearance_above(self.pos + 0.02 * UP, set(exclude) | self.held_bodies()) + 0.02
        up = min(height, max(0.0, room - 0.05))
        if up <= 0.003:
            return
        for fraction in (1.0, 0.6, 0.3):
            try:
                move = self.move(self.pos + fraction * up * UP, speed=APPROACH_SPEED, what="the lift")
            except SkillFailure:
                if required and fraction == 0.3:
                    raise
                continue
            yield move
            return

    def withdraw(self, distance: float) -> Iterator[Move]:
        """Move the empty hand back along its approach axis by up to ``distance`` (less where the arm cannot)."""
        for fraction in (1.0, 0.5):
            try:
                move = self.move(self.pos - fraction * distance * self.rot[:, 2], speed=APPROACH_SPEED, what="backing off")
            except SkillFailure:
                continue
            yield move
            return


_RUNTIMES: dict[str, Skill] = {}


def skill(name: str) -> Callable[[Skill], Skill]:
    """Register the runtime of the skill step type ``name`` (:mod:`pipette_cli.specs.expert`)."""

    def decorate(fn: Skill) -> Skill:
        if name in _RUNTIMES and _RUNTIMES[name] is not fn:
            raise ValueError(f"skill {name!r} is registered twice")
        _RUNTIMES[name] = fn
        return fn

    return decorate


def skill_runtime(name: str) -> Skill:
    import pipette_cli.skills.library  # noqa: F401  (registers the built-in skills)

    try:
        return _RUNTIMES[name]
    except KeyError:
        from pipette_cli.errors import suggest

        raise SkillFailure(f"no runtime for skill {name!r}; {suggest(name, _RUNTIMES)}") from None


def _pose_key(pos: np.ndarray, rot: np.ndarray) -> tuple:
    return tuple(np.round(np.asarray(pos, float), 3)) + tuple(np.round(np.asarray(rot, float), 2).flatten())
