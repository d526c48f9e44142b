"""Paths for the hand: over what stands between here and there, round it, or level out through an
enclosure's mouth; each leg checked reachable and touching nothing (see :meth:`SkillContext.transit`)."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from collections.abc import Set as AbstractSet
from typing import TYPE_CHECKING

import numpy as np

from pipette_cli.skills.frames import UP
from pipette_cli.skills.moves import (
    APPROACH_SPEED,
    CLEARANCE,
    COVER_ROOM,
    FINAL_APPROACH,
    FINE_SPEED,
    FREE_TOLERANCE,
    HAND_HEIGHT,
    TRANSIT_ROOM,
    TRANSIT_SPEED,
    Leg,
    Move,
    SkillFailure,
    fmt,
)

if TYPE_CHECKING:
    from pipette_cli.skills.runtime import SkillContext

log = logging.getLogger(__name__)

SETTLE_TOLERANCE = 0.001
"""Metres the tcp may stand from its planned pose after :func:`settle`."""
SETTLE_TRIES = 2


def transit(
    ctx: SkillContext,
    pos: np.ndarray,
    rot: np.ndarray,
    *,
    exclude: AbstractSet[int] = frozenset(),
    radius: float = 0.04,
    what: str = "the approach",
) -> Iterator[Move]:
    """Go to ``pos``/``rot`` over whatever stands in between (see :meth:`plan_transit`)."""
    legs = plan_transit(ctx, pos, rot, exclude=exclude, radius=radius)
    if legs is None:
        raise SkillFailure(
            f"{what}: no path to {fmt(np.asarray(pos))} within the {ctx.robot.name}'s reach "
            "that touches nothing on the way"
        )
    yield from follow(ctx, legs)


def follow(ctx: SkillContext, legs: list[Leg]) -> Iterator[Move]:
    """The moves along legs :func:`plan_transit` planned."""
    for leg in legs:
        yield ctx.planned(leg.pos, leg.rot, leg.q, speed=leg.speed, straight=leg.straight, joints=leg.joints)


def can_reach(ctx: SkillContext, pos: np.ndarray, rot: np.ndarray, exclude: AbstractSet[int] = frozenset()) -> bool:
    """Whether :meth:`transit` finds a path from the hand to ``pos``/``rot``."""
    return plan_transit(ctx, pos, rot, exclude=exclude) is not None


def plan_transit(
    ctx: SkillContext,
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
    skip = set(exclude) | ctx.held_bodies()
    # what hangs below the hand, as it is or turned to ``rot`` (it may turn anywhere on the way)
    hang = max(ctx.hang(), ctx.hang_at(rot)) if ctx.held else 0.012
    if ctx.held is not None:
        radius = max(radius, float(np.max(ctx.scene.shape(ctx.held.name).world_half()[:2])) + 0.02)
    start = Leg(ctx.pos, ctx.rot, ctx.q, TRANSIT_SPEED)
    legs: list[Leg] = []
    if covered(ctx, ctx.pos, skip):
        direction, mouth = ctx.scene.way_out(ctx.pos, skip, prefer=ctx.base - ctx.pos)
        out = ctx.pos + direction * (mouth + 0.05)
        out[2] += 0.01
        leg = _reach(ctx, start, out, ctx.rot, APPROACH_SPEED, 0.004, keep=True)
        if leg is None:
            return None
        legs.append(leg)
        start = leg
    route = [pos]
    if covered(ctx, pos, skip):
        direction, mouth = ctx.scene.way_out(pos + 0.01 * UP, skip, prefer=ctx.base - pos)
        route.insert(0, pos + direction * (mouth + radius + 0.02))
    first = route[0]
    if np.linalg.norm(first[:2] - start.pos[:2]) > 0.01:
        crossing = _route(ctx, start, first, rot, skip, radius, hang, precise=len(route) == 1)
        if crossing is None:
            log.debug("no route to %s", fmt(first))
            return None
        legs += crossing
    else:
        leg = _reach(ctx, start, first, rot, APPROACH_SPEED, 0.004 if len(route) == 1 else FREE_TOLERANCE)
        if leg is None:
            return None
        legs.append(leg)
    for point in route[1:]:  # level through the mouth of the enclosure
        leg = _reach(ctx, legs[-1], point, rot, APPROACH_SPEED, 0.004, keep=True)
        if leg is None:
            log.debug("no way through the mouth to %s", fmt(point))
            return None
        legs.append(leg)
    return legs


def _reach(
    ctx: SkillContext,
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
        if not keep and ctx.held is None:
            rot = ctx.nearest_flip(rot, start.rot)
        q = ctx.straight_line(start, point, rot, tolerance)
        return None if q is None else Leg(np.asarray(point, float), rot, q, speed)
    if keep:
        solution = ctx.solve(point, rot, start.q)
    else:
        rot, solution = ctx.solve_flip(point, rot, start.q)
    if solution.ok(tolerance) and ctx.clear_path(start.q, solution.qpos):
        return Leg(np.asarray(point, float), rot, solution.qpos, speed)
    return None


def _route(
    ctx: SkillContext,
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
    paths += [
        ([here_flat + s * d * side, goal + s * d * side, goal], True, 0.0) for d in (0.3, 0.42) for s in (1.0, -1.0)
    ]
    for room in (TRANSIT_ROOM, 0.0):
        for path, low, extra in paths:
            if low is None:  # straight there, where nothing is in the way (cramped spots near the base)
                if ctx.held is not None and _sweeps_held(ctx, here, goal, rot, skip, radius):
                    continue
                points: list[tuple[np.ndarray, bool | None]] | None = [(goal.copy(), True)]
            else:
                points = _waypoints(ctx, here, path, goal, skip, radius, hang, low, extra)
            if points is None:
                continue
            resolved = _feasible(ctx, start, points, rot, precise, room)
            if resolved is not None:
                return resolved
    return None


SWEEP_STEP = 0.02
"""Metres between the points of a straight carry at which what the hand holds is checked against what is under it."""


def _sweeps_held(
    ctx: SkillContext, here: np.ndarray, goal: np.ndarray, rot: np.ndarray, skip: set[int], radius: float
) -> bool:
    """Whether what the hand holds, carried straight from ``here`` to ``goal`` (turning to ``rot`` on the
    way), would sweep through something standing under the way: at some point of the way, a surface
    under the hand (what is higher than the hand, an overhang, does not count) reaches above the held
    object's lower end there (it goes down or up with the hand, as far below it as it hangs at the
    lower end). The arm's own path is checked joint by joint; what it carries is not (a pipette turned
    upright on the way to a stand's slot swept through the stand). Judged point by point, not by the
    way's highest surface against its lowest end: a dish lowered from an incubator's shelf toward the
    bench passes over that shelf high and over the bench low."""
    hang = max(ctx.hang(), ctx.hang_at(rot))
    steps = max(2, int(np.ceil(float(np.linalg.norm(goal - here)) / SWEEP_STEP)) + 1)
    for t in np.linspace(0.0, 1.0, steps):
        point = (1.0 - t) * here + t * goal
        if ctx.scene.corridor_top(point, point, radius, skip, below=float(point[2])) > point[2] - hang:
            return True
    return False


def _waypoints(
    ctx: SkillContext,
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
        over = ctx.scene.corridor_top(pos, end, radius, skip) + CLEARANCE + hang + extra
        z = max(over, floor)
        if low:
            z = max(pos[2], floor)
            under = ctx.scene.corridor_top(pos, end, radius, skip, below=z + HAND_HEIGHT)
            if under + CLEARANCE + hang > z:  # something in the way at this height: climb over it all
                z = max(over, z)
        if z > pos[2] + 0.005:
            if ctx.scene.clearance_above(pos, skip) < z - pos[2] + HAND_HEIGHT:
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
    ctx: SkillContext,
    start: Leg,
    points: list[tuple[np.ndarray, bool | None]],
    rot: np.ndarray,
    precise: bool = True,
    room: float = 0.0,
) -> list[Leg] | None:
    """Legs through ``points`` when the arm reaches each in turn touching nothing (keeping ``room``
    on the fast legs), else ``None``. The hand keeps its rotation while climbing and crossing and
    turns on the last leg; it turns earlier where keeping it is out of reach up there, and arrives
    unturned where turning is."""
    q, current = start.q, start.rot
    out: list[Leg] = []
    turned = False
    for i, (point, last) in enumerate(points):
        final = i == len(points) - 1
        tolerance = 0.004 if precise and final else FREE_TOLERANCE
        if last is None:  # a straight descent onto the goal, turned to its rotation on the way
            target = current if turned else ctx.nearest_flip(rot, current)
            reached = ctx.straight_line(
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
                solution = ctx.solve(point, target, q)
            else:
                target, solution = ctx.solve_flip(point, target, q, best=True)
            slow = final and precise
            if not solution.ok(tolerance) or not ctx.clear_path(q, solution.qpos, room=0.0 if slow else room):
                continue
            joints = False
            if slow and ctx.held is None:  # followed as a straight tool line where the arm can, else
                # through joint space (an empty hand only: what it holds would swing on the arc)
                begin = Leg(out[-1].pos if out else start.pos, current, q, APPROACH_SPEED)
                joints = ctx.straight_line(begin, point, target, tolerance) is None
                if joints and room > 0 and not ctx.clear_path(q, solution.qpos, room=room):
                    continue  # a joint-space leg keeps its room, slow or not
            turned = turned or not keep
            q, current = solution.qpos, target
            out.append(Leg(point, target, q, APPROACH_SPEED if slow else TRANSIT_SPEED, joints=joints))
            break
        else:
            return None
    return out


def covered(ctx: SkillContext, point: np.ndarray, exclude: set[int], room: float = COVER_ROOM) -> bool:
    """Whether something overhead (a shelf, a roof) is within ``room`` metres above ``point``."""
    return ctx.scene.clearance_above(np.asarray(point, float) + 0.01 * UP, exclude) < room


def leave_enclosure(ctx: SkillContext, exclude: set[int]) -> Iterator[Move]:
    """Back the hand (and what it holds) out of whatever covers it, level, toward the robot."""
    direction, mouth = ctx.scene.way_out(ctx.pos, set(exclude) | ctx.held_bodies(), prefer=ctx.base - ctx.pos)
    start = Leg(ctx.pos, ctx.rot, ctx.q, APPROACH_SPEED)
    for extra in (0.05, 0.03, 0.08):
        out = ctx.pos + direction * (mouth + extra)
        out[2] += 0.01
        leg = _reach(ctx, start, out, ctx.rot, APPROACH_SPEED, FREE_TOLERANCE, keep=True)
        if leg is not None:
            yield ctx.planned(leg.pos, leg.rot, leg.q, speed=APPROACH_SPEED)
            return
    raise SkillFailure(f"no way out of the enclosure from {fmt(ctx.pos)} that touches nothing")


def lift_clear(
    ctx: SkillContext, height: float, exclude: AbstractSet[int] = frozenset(), *, required: bool = False
) -> Iterator[Move]:
    """Lift by ``height``: less where something is overhead or the arm cannot go higher (unless
    ``required``, when a lift the arm cannot make fails the skill)."""
    room = ctx.scene.clearance_above(ctx.pos + 0.02 * UP, set(exclude) | ctx.held_bodies()) + 0.02
    up = min(height, max(0.0, room - 0.05))
    if up <= 0.003:
        return
    for fraction in (1.0, 0.6, 0.3):
        try:
            move = ctx.move(ctx.pos + fraction * up * UP, speed=APPROACH_SPEED, what="the lift")
        except SkillFailure:
            if required and fraction == 0.3:
                raise
            continue
        yield move
        return


def settle(
    ctx: SkillContext,
    seconds: float,
    *,
    what: str,
    required: bool = True,
    vertical: Callable[[], bool] | None = None,
) -> Iterator[Move]:
    """Hold still ``seconds``, then bring the tcp sideways to where the last move planned it: a
    position servo under gravity stops a few millimetres short of its target (an outstretched arm
    sags), so a held object is set down off the spot planned. The target is moved by the sideways
    error measured, up to :data:`SETTLE_TRIES` times, until the tcp is within
    :data:`SETTLE_TOLERANCE` of the plan; the height is left alone (what the hand holds stays
    pressed on the surface under it) unless ``vertical``, asked once the hand has come to rest,
    says otherwise: then a tcp that sagged below the plan is raised to it too (never pushed down).
    Unless ``required``, a correction the arm cannot make is left out."""
    goal, rot = ctx.pos.copy(), ctx.rot
    yield ctx.hold(seconds)
    raise_too = vertical is not None and vertical()
    for _ in range(SETTLE_TRIES):
        error = goal - ctx.world.tcp_position()
        error[2] = max(error[2], 0.0) if raise_too else 0.0
        if float(np.linalg.norm(error)) < SETTLE_TOLERANCE:
            break
        try:
            move = ctx.move(ctx.pos + error, rot, speed=FINE_SPEED, what=what)
        except SkillFailure:
            if required:
                raise
            return
        yield move
        yield ctx.hold(seconds)


def withdraw(ctx: SkillContext, distance: float) -> Iterator[Move]:
    """Move the empty hand back along its approach axis by up to ``distance`` (less where the arm cannot)."""
    for fraction in (1.0, 0.5):
        try:
            move = ctx.move(ctx.pos - fraction * distance * ctx.rot[:, 2], speed=APPROACH_SPEED, what="backing off")
        except SkillFailure:
            continue
        yield move
        return
