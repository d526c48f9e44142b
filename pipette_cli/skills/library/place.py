"""``place_on``, ``insert_into`` and ``move``: carry what the hand holds and set it down.

Targets resolve to a point on a surface: a site (``balance/pan_center``) stands on its surface; an
object without a named site means the middle of its top; ``{at, offset}`` and ``{point}`` are
dropped onto whatever surface is under them (:mod:`pipette_cli.skills.targets`). The held object keeps the orientation it was grasped
with (it stays level), and its base, measured in the hand after the grasp, lands on the surface.
"""

from __future__ import annotations

import logging
from collections.abc import Generator, Iterator

import numpy as np

from pipette_cli.skills.frames import UP, rotation_angle, unit
from pipette_cli.skills.handling import put_down
from pipette_cli.skills.insertion import REGRASP_RETREAT, let_go, line_up, push_home, standing_error
from pipette_cli.skills.motions import back_off, transit
from pipette_cli.skills.moves import (
    APPROACH_SPEED,
    FINE_SPEED,
    Held,
    Move,
    SkillFailure,
)
from pipette_cli.skills.runtime import SkillContext, skill
from pipette_cli.skills.targets import (
    SEATED,
    finger_floor,
    insertion,
    lowest_along_axis,
    resolve_target,
    seat_gap,
    standing_in,
    upright_rotations,
)
from pipette_cli.specs.expert import InsertIntoSpec, MoveSpec, PlaceOnSpec

log = logging.getLogger(__name__)


@skill(PlaceOnSpec)
def place_on(ctx: SkillContext, step: PlaceOnSpec) -> Iterator[Move]:
    target = resolve_target(ctx, step.target)
    yield from put_down(ctx, step.object, target, release=step.release, retreat=step.retreat)


def upright_tool(ctx: SkillContext, name: str) -> list[np.ndarray]:
    """Tool rotations that hold ``name`` with its own z axis straight up, nearest the current one first."""
    return upright_rotations(ctx.hand.holding(name), ctx.hand.rot)


SLIDE_LIFT = 0.005
"""Metres over its seat a held object slides into a slot open at the side (its collar clears the prongs)."""
SLIDE_ROOM = 0.03
"""Metres beyond the holder's side where a slide into a slot open at that side starts."""


def slot_opening(ctx: SkillContext, target: str) -> np.ndarray | None:
    """The horizontal world direction from which a held object slides into ``target``'s slots, where
    its asset says they are open at the side (``slot_opening``: a pipette stand's slots open to the
    front), else ``None``."""
    holder = target.split("/", 1)[0]
    opening = ctx.scene.semantics(holder).get("slot_opening")
    if opening is None:
        return None
    direction = ctx.world.rotation(holder) @ np.asarray(opening, dtype=float)
    direction[2] = 0.0
    return unit(direction)


def _beyond(ctx: SkillContext, holder: str, site: np.ndarray, direction: np.ndarray) -> float:
    """Metres from ``site`` along ``direction`` to the side of the holder's box, and :data:`SLIDE_ROOM` more."""
    shape = ctx.scene.shape(holder)
    p, d = shape.axes.T @ (site - shape.center), shape.axes.T @ direction
    exits = [(np.sign(d[i]) * shape.half[i] - p[i]) / d[i] for i in range(3) if abs(d[i]) > 1e-9]
    return max(0.0, min(exits)) + SLIDE_ROOM


@skill(InsertIntoSpec)
def insert_into(ctx: SkillContext, step: InsertIntoSpec) -> Iterator[Move]:
    held = ctx.hand.holding(step.object)
    rotations = upright_tool(ctx, step.object) if step.axis == "auto" else [ctx.hand.rot]
    holder_name = step.target.split("/", 1)[0]
    holder = ctx.scene.bodies(holder_name)
    placed, rise = insertion(ctx, step, ctx.hand.held_bodies())
    # lowered in from over the holder; where its slots are open at the side, slid in from there first
    # (as a pipette is hung by hand: no lift over the holder, which a short arm may not reach)
    ways: list[tuple[str, np.ndarray]] = [("down", rise * UP)]
    opening = slot_opening(ctx, step.target)
    if opening is not None:
        site = ctx.world.position(step.target)
        ways.insert(0, ("slide", _beyond(ctx, holder_name, site, opening) * opening + SLIDE_LIFT * UP))

    def final(tool_rot: np.ndarray, held: Held = held) -> np.ndarray:
        return placed(tool_rot, held)

    def path(way: tuple[str, np.ndarray], tool_rot: np.ndarray, held: Held = held) -> list[np.ndarray]:
        """The tcp's points from the entry to the seat (the entry first)."""
        kind, offset = way
        end = final(tool_rot, held)
        if kind == "slide":
            return [end + offset, end + SLIDE_LIFT * UP, end]
        return [end + offset, end]

    def choose() -> tuple[tuple[str, np.ndarray], np.ndarray] | None:
        for way in ways:  # a way in order, the most comfortable rotation for it (not the other way round)
            chosen = ctx.plan.choose(
                [(way, r) for r in rotations],
                lambda c: [(p, c[1]) for p in path(*c)],
                touch=holder,
                via=lambda c: (path(*c)[0], c[1]),
            )
            if chosen is not None:
                return chosen
        return None

    chosen = choose()
    if chosen is None and step.axis == "auto":
        # a short arm may not turn it upright on the way (carried lying, held far out): stand it up
        # where it is first, then carry it upright
        stood = yield from _stand_up(ctx, step.object)
        chosen = choose() if stood else None
    if chosen is None:
        raise SkillFailure(
            f"no reachable way to hold {step.object!r} upright over {step.target!r} without touching anything"
        )
    way, tool_rot = chosen
    yield from transit(ctx, path(way, tool_rot)[0], tool_rot, what=f"carrying {step.object!r} to {step.target!r}")
    yield ctx.hold(0.3)  # let it stop swinging in the fingers

    def entry() -> tuple[np.ndarray, np.ndarray]:
        # the object may have turned or slipped in the grasp: measured again, held truly upright
        # (when the axis is auto) with its mating point over the site
        held = ctx.hand.holding(step.object)
        rot = upright_tool(ctx, step.object)[0] if step.axis == "auto" else tool_rot
        return path(way, rot, held)[0], rot

    tool_rot = yield from line_up(ctx, entry, what=f"lining {step.object!r} up with {step.target!r}")
    offset = standing_error(ctx)  # carried into the hole: the moves there are measured, not commanded
    points = path(way, tool_rot, ctx.hand.holding(step.object))[1:]
    site = ctx.world.position(step.target)
    # down to its seat, the arm's sag pressing it on (only the sideways error is taken out); but no
    # lower than the closed fingers allow over what surrounds the hole, the sag taken out too
    floor = finger_floor(ctx, step.object, points[-1], tool_rot) if way[0] == "down" else -np.inf
    blocked = bool(points[-1][2] < floor)
    goals = [p + offset * np.array([1.0, 1.0, 0.0]) for p in points]
    if blocked:
        goals[-1] = np.array([*points[-1][:2], floor]) + offset
    with ctx.hand.touching(holder):
        for goal in goals:
            yield ctx.move(goal, tool_rot, speed=FINE_SPEED, what=f"inserting {step.object!r} into {step.target!r}")
        if not step.release:
            return
        yield ctx.hold(0.1)
        stuck = seat_gap(ctx, step.object, site) > SEATED
        yield from let_go(ctx, step.object, offset if blocked else None, REGRASP_RETREAT if stuck else step.retreat)
        if stuck and seat_gap(ctx, step.object, site) > SEATED and standing_in(ctx, step.object, site):
            yield from push_home(ctx, step.object, site, holder, step.retreat)
        elif stuck:
            yield from back_off(ctx, step.retreat)


STAND_CLEAR = 0.1
"""Metres over the surface below that the lower end of an object stood upright in the hand keeps."""
STAND_TURN_SPEED = 0.6
"""Radians per second the hand turns a held object upright at (a fast whole-arm turn squeezes a
narrow pipette out of a small gripper's pads)."""


def _stand_up(ctx: SkillContext, name: str) -> Generator[Move, None, bool]:
    """Turn held ``name`` upright where the hand is, its lower end :data:`STAND_CLEAR` over the
    surface below, through joint space (checked against swinging it round and touching anything);
    returns whether some upright hold was reachable that way."""
    held = ctx.hand.holding(name)
    lowest = lowest_along_axis(ctx, name)
    floor = ctx.scene.surface_below(ctx.hand.pos[0], ctx.hand.pos[1], ctx.hand.held_bodies(), from_z=ctx.hand.pos[2])
    for tool_rot in upright_tool(ctx, name):
        pos = ctx.hand.pos.copy()
        pos[2] = floor + STAND_CLEAR - lowest - (tool_rot @ held.pos)[2]
        seconds = rotation_angle(ctx.hand.rot, tool_rot) / STAND_TURN_SPEED
        try:
            move = ctx.move(pos, tool_rot, seconds=seconds, what=f"standing {name!r} up")
        except SkillFailure:
            continue
        yield move
        yield ctx.hold(0.3)  # let it stop swinging in the fingers
        return True
    return False


@skill(MoveSpec)
def move(ctx: SkillContext, step: MoveSpec) -> Iterator[Move]:
    if step.by is not None:
        yield ctx.move(ctx.hand.pos + np.asarray(step.by, dtype=float), speed=APPROACH_SPEED, what="the move")
    else:
        assert step.to is not None
        point = resolve_target(ctx, step.to, surface=False)
        if step.object is not None:
            ctx.hand.holding(step.object)
            tool_pos, tool_rot = ctx.hand.tool_for(step.object, point)
        else:
            tool_pos, tool_rot = point, ctx.hand.rot
        yield from transit(ctx, tool_pos, tool_rot, what="the move")
    if step.hold_s:
        yield ctx.hold(step.hold_s)
