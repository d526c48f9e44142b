"""The planner: reach (:mod:`.reach`) and paths for the hand over whatever stands between here and
there, round it, or level out through an enclosure's mouth; each leg checked reachable and touching
nothing. Skills ask it through ``ctx.plan``; the motions that follow its paths are in :mod:`.motions`."""

from __future__ import annotations

import logging
from collections.abc import Callable
from collections.abc import Set as AbstractSet
from typing import Any

import numpy as np

from pipette_cli.sim.world import World
from pipette_cli.skills.frames import UP
from pipette_cli.skills.hand import FINGERTIP, Hand
from pipette_cli.skills.ik import ArmIK
from pipette_cli.skills.moves import (
    APPROACH_SPEED,
    CLEARANCE,
    COMFORT,
    COVER_ROOM,
    ENOUGH,
    FINAL_APPROACH,
    FREE_TOLERANCE,
    HAND_HEIGHT,
    TRANSIT_ROOM,
    TRANSIT_SPEED,
    Leg,
    fmt,
)
from pipette_cli.skills.reach import Reach
from pipette_cli.skills.scene import SceneQuery

log = logging.getLogger(__name__)

SWEEP_STEP = 0.02
"""Metres between the points of a straight carry at which what the hand holds is checked against what is under it."""


class Planner(Reach):
    """Reach (inherited) and the hand's paths through the scene, planned from the hand's state."""

    def __init__(self, world: World, ik: ArmIK, scene: SceneQuery, hand: Hand) -> None:
        super().__init__(world, ik, hand)
        self.scene = scene
        self.base = np.asarray(world.task.embodiment.base.pos, dtype=float)

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
                legs = self.path(target[0], target[1], exclude=target[2] if len(target) > 2 else frozenset())
                if legs is None:
                    continue
                hand = self.hand
                start = legs[-1] if legs else Leg(hand.pos, hand.rot, hand.q, APPROACH_SPEED)
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

    def can_reach(self, pos: np.ndarray, rot: np.ndarray, exclude: AbstractSet[int] = frozenset()) -> bool:
        """Whether :meth:`path` finds a path from the hand to ``pos``/``rot``."""
        return self.path(pos, rot, exclude=exclude) is not None

    def path(
        self,
        pos: np.ndarray,
        rot: np.ndarray,
        *,
        exclude: AbstractSet[int] = frozenset(),
        radius: float = 0.04,
    ) -> list[Leg] | None:
        """The legs from the hand to ``pos``/``rot``, each reached by the arm without touching anything
        (dry run of the IK and of the arm's collisions), or ``None``. The fast legs keep
        :data:`TRANSIT_ROOM` from the scene where some path has that room.

        Out of an enclosure the hand is in, level; then up to a safe height over the corridor (surfaces
        under the path plus what hangs below the hand), across and down, or, when that is out of the
        arm's reach, at the hand's height where it is free or round the side; into a covered
        destination (a shelf under a roof) level through its mouth.
        """
        pos = np.asarray(pos, dtype=float)
        skip = set(exclude) | self.hand.held_bodies()
        # what hangs below the hand, as it is or turned to ``rot`` (it may turn anywhere on the way)
        hang = max(self.hand.hang(), self.hand.hang_at(rot)) if self.hand.held else FINGERTIP
        if self.hand.held is not None:
            radius = max(radius, float(np.max(self.scene.shape(self.hand.held.name).world_half()[:2])) + 0.02)
        start = Leg(self.hand.pos, self.hand.rot, self.hand.q, TRANSIT_SPEED)
        legs: list[Leg] = []
        if self.covered(self.hand.pos, skip):
            direction, mouth = self.scene.way_out(self.hand.pos, skip, prefer=self.base - self.hand.pos)
            out = self.hand.pos + direction * (mouth + 0.05)
            out[2] += 0.01
            leg = self.leg(start, out, self.hand.rot, APPROACH_SPEED, 0.004, keep=True)
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
            leg = self.leg(start, first, rot, APPROACH_SPEED, 0.004 if len(route) == 1 else FREE_TOLERANCE)
            if leg is None:
                return None
            legs.append(leg)
        for point in route[1:]:  # level through the mouth of the enclosure
            leg = self.leg(legs[-1], point, rot, APPROACH_SPEED, 0.004, keep=True)
            if leg is None:
                log.debug("no way through the mouth to %s", fmt(point))
                return None
            legs.append(leg)
        return legs

    def leg(
        self,
        start: Leg,
        point: np.ndarray,
        rot: np.ndarray,
        speed: float,
        tolerance: float,
        keep: bool = False,
    ) -> Leg | None:
        """The leg from ``start`` to ``point``/``rot`` if the arm reaches it touching nothing: along a
        straight tool line below transit speed (as it will be executed), through joint space above it."""
        if keep:
            rot = start.rot
        if speed < TRANSIT_SPEED:
            if not keep and self.hand.held is None:
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

    def _route(
        self,
        start: Leg,
        goal: np.ndarray,
        rot: np.ndarray,
        skip: set[int],
        radius: float,
        hang: float,
        precise: bool = True,
    ) -> list[Leg] | None:
        """Legs from ``start`` to ``goal``: straight over the top, at the hand's height, or by a detour to
        either side; the first the arm reaches touching nothing, with :data:`TRANSIT_ROOM` to spare where
        any path has it."""
        here = start.pos
        heading = goal[:2] - here[:2]
        heading = heading / (np.linalg.norm(heading) + 1e-12)
        side = np.array([-heading[1], heading[0], 0.0])
        here_flat = np.array([here[0], here[1], goal[2]])
        paths: list[tuple[list[np.ndarray], bool | None, float]] = [([goal], False, 0.0), ([goal], True, 0.0)]
        paths += [([goal], None, 0.0)]
        # higher over the top before round the side: the arm that cannot cross just over an obstacle
        # (an open lid standing up) often can higher up, and a detour is long and passes the base
        paths += [([goal], False, extra) for extra in (0.08, 0.16)]
        # what the hand holds goes straight where an arc would swing it before the long way round the base
        tries = [(path, False) for path in paths] + [(path, True) for path in paths if self.hand.held is not None]
        detours = [
            ([here_flat + s * d * side, goal + s * d * side, goal], True, 0.0) for d in (0.3, 0.42) for s in (1, -1)
        ]
        tries += [(path, False) for path in detours]
        for room in (TRANSIT_ROOM, 0.0):
            for (path, low, extra), carry in tries:
                if low is None:  # straight there, where nothing is in the way (cramped spots near the base)
                    if self.hand.held is not None and self._sweeps_held(here, goal, rot, skip, radius):
                        continue
                    points: list[tuple[np.ndarray, bool | None]] | None = [(goal.copy(), True)]
                else:
                    points = self._waypoints(here, path, goal, skip, radius, hang, low, extra)
                if points is None:
                    continue
                resolved = self._feasible(start, points, rot, precise, room, carry)
                if resolved is not None:
                    return resolved
        return None

    def _sweeps_held(self, here: np.ndarray, goal: np.ndarray, rot: np.ndarray, skip: set[int], radius: float) -> bool:
        """Whether what the hand holds, carried straight from ``here`` to ``goal`` (turning to ``rot`` on the
        way), would sweep through something standing under the way: at some point of the way, a surface
        under the hand (what is higher than the hand, an overhang, does not count) reaches above the held
        object's lower end there (it goes down or up with the hand, as far below it as it hangs at the
        lower end). The arm's own path is checked joint by joint; what it carries is not (a pipette turned
        upright on the way to a stand's slot swept through the stand). Judged point by point, not by the
        way's highest surface against its lowest end: a dish lowered from an incubator's shelf toward the
        bench passes over that shelf high and over the bench low."""
        hang = max(self.hand.hang(), self.hand.hang_at(rot))
        steps = max(2, int(np.ceil(float(np.linalg.norm(goal - here)) / SWEEP_STEP)) + 1)
        for t in np.linspace(0.0, 1.0, steps):
            point = (1.0 - t) * here + t * goal
            if self.scene.corridor_top(point, point, radius, skip, below=float(point[2])) > point[2] - hang:
                return True
        return False

    def _waypoints(
        self,
        here: np.ndarray,
        path: list[np.ndarray],
        goal: np.ndarray,
        skip: set[int],
        radius: float,
        hang: float,
        low: bool,
        extra: float = 0.0,
    ) -> list[tuple[np.ndarray, bool | None]] | None:
        """Climb-and-cross waypoints through ``path`` (and whether each is on the last leg): ``extra``
        metres over everything under each leg, or (``low``) at the hand's height where that band is free
        (under an overhang, beside an instrument)."""
        points: list[tuple[np.ndarray, bool | None]] = []
        pos = here.copy()
        for i, end in enumerate(path):
            last = i == len(path) - 1
            floor = goal[2] if last else 0.0
            over = self.scene.corridor_top(pos, end, radius, skip) + CLEARANCE + hang + extra
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

    def _feasible(
        self,
        start: Leg,
        points: list[tuple[np.ndarray, bool | None]],
        rot: np.ndarray,
        precise: bool = True,
        room: float = 0.0,
        carry: bool = False,
    ) -> list[Leg] | None:
        """Legs through ``points`` when the arm reaches each in turn touching nothing (keeping ``room``
        on the fast legs), else ``None``. The hand keeps its rotation while climbing and crossing and
        turns on the last leg; it turns earlier where keeping it is out of reach up there, and arrives
        unturned where turning is. With ``carry``, what the hand holds goes along a straight line to a
        point its joint-space arc cannot reach without swinging it, dipping it or touching something."""
        q, current = start.q, start.rot
        out: list[Leg] = []
        turned = False
        for i, (point, last) in enumerate(points):
            final = i == len(points) - 1
            tolerance = 0.004 if precise and final else FREE_TOLERANCE
            if last is None:  # a straight descent onto the goal, turned to its rotation on the way
                target = current if turned else self.nearest_flip(rot, current)
                reached = self.straight_line(
                    Leg(out[-1].pos if out else start.pos, current, q, TRANSIT_SPEED), point, target, tolerance
                )
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
                slow = final and precise
                if not solution.ok(tolerance):
                    continue
                here, qpos, joints, straight = out[-1].pos if out else start.pos, solution.qpos, False, False
                if not self.clear_path(q, qpos, room=0.0 if slow else room):
                    line = Leg(here, current, q, TRANSIT_SPEED)
                    carried = (
                        self.straight_line(line, point, target, tolerance, 0.0 if slow else room) if carry else None
                    )
                    if carried is None:
                        continue
                    qpos, straight = carried, True
                elif slow and self.hand.held is None:  # followed as a straight tool line where the arm can, else
                    # through joint space (an empty hand only: what it holds would swing on the arc)
                    joints = self.straight_line(Leg(here, current, q, APPROACH_SPEED), point, target, tolerance) is None
                    if joints and room > 0 and not self.clear_path(q, qpos, room=room):
                        continue  # a joint-space leg keeps its room, slow or not
                turned = turned or not keep
                q, current = qpos, target
                out.append(
                    Leg(point, target, q, APPROACH_SPEED if slow else TRANSIT_SPEED, joints=joints, straight=straight)
                )
                break
            else:
                return None
        return out

    def covered(self, point: np.ndarray, exclude: set[int], room: float = COVER_ROOM) -> bool:
        """Whether something overhead (a shelf, a roof) is within ``room`` metres above ``point``."""
        return self.scene.clearance_above(np.asarray(point, float) + 0.01 * UP, exclude) < room
