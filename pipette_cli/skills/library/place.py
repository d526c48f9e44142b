"""``place_on``, ``insert_into`` and ``move``: carry what the hand holds and set it down.

Targets resolve to a point on a surface: a site (``balance/pan_center``) stands on its surface; an
object without a named site means the middle of its top; ``{at, offset}`` and ``{point}`` are
dropped onto whatever surface is under them. The held object keeps the orientation it was grasped
with (it stays level), and its base, measured in the hand after the grasp, lands on the surface.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Generator, Iterator

import numpy as np

from pipette_cli.skills.frames import UP, axis_rotation, rotation_angle, tool_frame, unit
from pipette_cli.skills.grasp import semantics
from pipette_cli.skills.motions import back_off, settle_hand, transit
from pipette_cli.skills.moves import (
    APPROACH_SPEED,
    CLOSED,
    FINE_SPEED,
    OPEN,
    SHIFT_STEP,
    SHIFTS,
    Held,
    Move,
    SkillFailure,
    fmt,
)
from pipette_cli.skills.runtime import SkillContext, skill
from pipette_cli.specs.expert import InsertIntoSpec, MoveSpec, PlaceOnSpec, TargetSpec

log = logging.getLogger(__name__)

DROP = 0.002
"""Metres above the surface where a placed object is let go."""
YAWS = (0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0, 135.0, -135.0, 180.0)
"""Degrees the held object may be turned about the vertical when set down, in the order tried."""
RELEASE_S = 0.4
SETTLE_S = 0.2
"""Seconds the arm holds still where it sets an object down before its tcp is corrected."""


def resolve_target(ctx: SkillContext, target: str | TargetSpec, *, surface: bool = True) -> np.ndarray:
    """The world point ``target`` names; with ``surface``, dropped onto the surface under it."""
    if isinstance(target, str):
        spec = TargetSpec(at=target)
    else:
        spec = target
    if spec.point is not None:
        point = np.asarray(spec.point, dtype=float) + np.asarray(spec.offset)
    else:
        assert spec.at is not None
        if spec.relative_to_start:
            head = spec.at.split("/", 1)[0]
            point = ctx.start[head] + (ctx.world.position(spec.at) - ctx.world.position(head))
        elif "/" in spec.at:
            point = ctx.world.position(spec.at)
        else:
            point = _top_of(ctx, spec.at)
        point = point + np.asarray(spec.offset)
    if surface:
        skip = ctx.hand.held_bodies()
        point = point.copy()
        point[2] = ctx.scene.surface_below(point[0], point[1], skip, from_z=point[2] + 0.03)
    return point


def _top_of(ctx: SkillContext, name: str) -> np.ndarray:
    """The middle of an object's top: its ``*center`` site if its asset names one, else its box."""
    centers = [s for s in semantics(ctx, name).get("sites", []) if str(s).endswith("center")]
    if centers:
        return ctx.world.position(f"{name}/{centers[0]}")
    shape = ctx.scene.shape(name)
    return np.array([shape.center[0], shape.center[1], shape.top])


def base_offset(ctx: SkillContext, name: str) -> float:
    """How far the object's origin is above its lowest point (0 for assets authored on their base)."""
    return float(ctx.world.position(name)[2] - ctx.scene.shape(name).bottom)


def put_down(
    ctx: SkillContext, name: str, surface_point: np.ndarray, *, release: bool = True, retreat: float = 0.08
) -> Iterator[Move]:
    """Carry held ``name`` so its base rests on ``surface_point``, let go and back off."""
    ctx.hand.holding(name)
    lift = base_offset(ctx, name) + DROP
    support = _support(ctx, surface_point)
    spot = _reachable_spot(ctx, name, surface_point, lift, support)
    if spot is None:
        raise SkillFailure(f"no reachable spot to set {name!r} down at {fmt(surface_point)}")
    tool_pos, tool_rot, above = spot
    yield from transit(ctx, above, tool_rot, what=f"carrying {name!r} to {fmt(surface_point)}")
    with ctx.hand.touching(support):
        yield ctx.move(tool_pos, tool_rot, speed=FINE_SPEED, what=f"setting {name!r} down")
        if not release:
            return
        # over the spot planned; not lifted off the surface the servo's sag presses it on: let go in
        # the air, the fingers springing open throw a light object
        yield from settle_hand(ctx, SETTLE_S, what=f"setting {name!r} down")
        yield ctx.grip(OPEN, RELEASE_S)
        ctx.hand.held = None
        with ctx.hand.touching(ctx.scene.bodies(name)):
            yield from back_off(ctx, retreat)


def _reachable_spot(
    ctx: SkillContext, name: str, surface_point: np.ndarray, lift: float, support: set[int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Tool pose (and the point above it) setting ``name`` down at ``surface_point``, or, where the arm
    cannot reach that without touching anything, as near as the same surface allows toward the robot
    (a shelf's front rather than its back): ``(tool position, tool rotation, above)``."""
    skip = ctx.hand.held_bodies()
    half = float(np.max(ctx.scene.shape(name).world_half()[:2]))
    covered = ctx.plan.covered(surface_point + lift * UP, skip)
    if covered:
        toward, _ = ctx.scene.way_out(surface_point + 0.01 * UP, skip, prefer=ctx.base - surface_point)
    else:
        toward = ctx.base - surface_point
        toward[2] = 0.0
        toward /= np.linalg.norm(toward) + 1e-12
    for k in range(SHIFTS + 1):
        point = surface_point + k * SHIFT_STEP * toward
        if k and not _same_surface(ctx, point, surface_point[2], half, skip):
            break
        for yaw in YAWS:  # turning about the vertical keeps the object level
            held = ctx.hand.held
            assert held is not None
            obj_rot = axis_rotation(UP, np.deg2rad(yaw)) @ ctx.hand.rot @ held.rot
            tool_pos, tool_rot = ctx.hand.tool_for(name, point + lift * UP, obj_rot)
            above = tool_pos + (0.012 if covered else 0.05) * UP
            if ctx.plan.margin(
                [(above, tool_rot), (tool_pos, tool_rot)], touch=support
            ) is not None and ctx.plan.can_reach(above, tool_rot):
                return tool_pos, tool_rot, above
    return None


def _same_surface(ctx: SkillContext, point: np.ndarray, height: float, half: float, skip: set[int]) -> bool:
    """Whether an object of half-size ``half`` standing at ``point`` rests wholly on the surface at ``height``."""
    for dx in (-half, 0.0, half):
        for dy in (-half, 0.0, half):
            z = ctx.scene.surface_below(point[0] + dx, point[1] + dy, skip, from_z=height + 0.03)
            if abs(z - height) > 0.003:
                return False
    return True


def _support(ctx: SkillContext, point: np.ndarray) -> set[int]:
    """The bodies of the object whose surface ``point`` lies on (what a placed object rests on)."""
    _, body = ctx.scene.ray(point + 0.02 * UP, -UP, ctx.hand.held_bodies())
    owner = ctx.scene.owner(body) if body >= 0 else None
    return ctx.scene.bodies(owner) if owner else ({body} if body >= 0 else set())


@skill(PlaceOnSpec)
def place_on(ctx: SkillContext, step: PlaceOnSpec) -> Iterator[Move]:
    target = resolve_target(ctx, step.target)
    yield from put_down(ctx, step.object, target, release=step.release, retreat=step.retreat)


def mating_point(ctx: SkillContext, name: str) -> np.ndarray:
    """Where ``name`` meets a holder, in its own frame: where it hangs from (``hang_height`` above its
    origin, a pipette's collar) or its base (a tube)."""
    hang = semantics(ctx, name).get("hang_height")
    return np.array([0.0, 0.0, float(hang) if hang else 0.0])


def upright_tool(ctx: SkillContext, name: str) -> list[np.ndarray]:
    """Tool rotations that hold ``name`` with its own z axis straight up, nearest the current one first."""
    return upright_rotations(ctx.hand.holding(name), ctx.hand.rot)


def upright_rotations(held: Held, reference: np.ndarray) -> list[np.ndarray]:
    """Tool rotations holding ``held`` with its own z axis straight up, nearest ``reference`` first."""
    out = [axis_rotation(UP, yaw) @ held.rot.T for yaw in np.deg2rad(np.arange(0.0, 360.0, 30.0))]
    return sorted(out, key=lambda r: rotation_angle(reference, r))


def insertion(
    ctx: SkillContext, step: InsertIntoSpec, skip: set[int]
) -> tuple[Callable[[np.ndarray, Held], np.ndarray], float]:
    """Where the tcp ends for ``step`` given the tool rotation and the held pose (the object's mating
    point on the target site), and how high over that it enters (over the holder's rim, with what
    the object reaches below its mating point)."""
    site = ctx.world.position(step.target)
    mate = mating_point(ctx, step.object)
    rim = ctx.scene.corridor_top(site, site, 0.02, skip)
    below = mate[2] - _lowest_along_axis(ctx, step.object)  # how far the object reaches below its mating point
    rise = max(0.0, rim - site[2]) + below + 0.02

    def final(tool_rot: np.ndarray, held: Held) -> np.ndarray:
        return site + 0.003 * UP - (tool_rot @ held.rot) @ mate - tool_rot @ held.pos

    return final, rise


SLIDE_LIFT = 0.005
"""Metres over its seat a held object slides into a slot open at the side (its collar clears the prongs)."""
SLIDE_ROOM = 0.03
"""Metres beyond the holder's side where a slide into a slot open at that side starts."""


def slot_opening(ctx: SkillContext, target: str) -> np.ndarray | None:
    """The horizontal world direction from which a held object slides into ``target``'s slots, where
    its asset says they are open at the side (``slot_opening``: a pipette stand's slots open to the
    front), else ``None``."""
    holder = target.split("/", 1)[0]
    opening = semantics(ctx, holder).get("slot_opening")
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
    # closed loop: the object may have turned or slipped in the grasp. Measure it again, hold it truly
    # upright (when the axis is auto) with its mating point lined up with the site, and only then go in
    for _ in range(3):
        held = ctx.hand.holding(step.object)
        if step.axis == "auto":
            tool_rot = upright_tool(ctx, step.object)[0]
        entry = path(way, tool_rot, held)[0]
        if np.linalg.norm(entry - ctx.hand.pos) < 0.0015 and rotation_angle(ctx.hand.rot, tool_rot) < np.deg2rad(0.5):
            break
        log.debug(
            "insert %s at t=%.2f: correcting by %s, %.1f deg",
            step.object,
            ctx.world.time,
            fmt(entry - ctx.hand.pos),
            float(np.rad2deg(rotation_angle(ctx.hand.rot, tool_rot))),
        )
        yield ctx.move(entry, tool_rot, speed=FINE_SPEED, what=f"lining {step.object!r} up with {step.target!r}")
        yield ctx.hold(0.2)
    with ctx.hand.touching(holder):
        for point in path(way, tool_rot, held)[1:]:
            yield ctx.move(point, tool_rot, speed=FINE_SPEED, what=f"inserting {step.object!r} into {step.target!r}")
        if not step.release:
            return
        yield ctx.grip(OPEN, RELEASE_S)
        ctx.hand.held = None
        with ctx.hand.touching(ctx.scene.bodies(step.object)):
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
    lowest = _lowest_along_axis(ctx, name)
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


def _lowest_along_axis(ctx: SkillContext, name: str) -> float:
    """The object's lowest point along its own z axis (its own frame), from its collision geometry."""
    w = ctx.world
    m, d = w.model, w.data
    body = w.body_id(name)
    rot, origin = d.xmat[body].reshape(3, 3), d.xpos[body]
    low = np.inf
    for g in np.flatnonzero(m.geom_bodyid == body):
        if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
            continue
        grot = rot.T @ d.geom_xmat[g].reshape(3, 3)
        c = rot.T @ (d.geom_xpos[g] - origin) + grot @ m.geom_aabb[g, :3]
        low = min(low, float(c[2] - np.abs(grot[2]) @ m.geom_aabb[g, 3:]))
    return 0.0 if not np.isfinite(low) else low


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


__all__ = ["CLOSED", "put_down", "resolve_target", "tool_frame", "unit"]
