"""Taking hold of an object and setting it down: the motions that ``pick``, ``remove_from``, the
placing skills and the hinge and slide skills share.

:func:`grasp` approaches an object, closes on it and records it as held, choosing a grasp that
leaves the program's next step in reach; :func:`put_down` carries what the hand holds onto a
surface point, lets go and backs off.
"""

from __future__ import annotations

from collections.abc import Iterator
from collections.abc import Set as AbstractSet
from functools import partial

import numpy as np

from pipette_cli.skills.frames import UP, axis_rotation, horizontal
from pipette_cli.skills.grasp import FollowThrough, plan_grasp, support_of
from pipette_cli.skills.grasp_candidates import Grasp, closed_over
from pipette_cli.skills.grip import FINGERTIP_LIFT
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
from pipette_cli.skills.runtime import SkillContext
from pipette_cli.skills.targets import (
    SLIP_ROOM,
    base_offset,
    insertion,
    insertion_grasp,
    resolve_target,
    upright_rotations,
)
from pipette_cli.specs.expert import InsertIntoSpec, PositionOverSpec

GRASP_SETTLE_S = 0.25
"""Seconds to let the arm's servos catch up with the grasp pose before closing."""
CLOSE_S = 0.5
TOUCH_FORCE = 2.0
"""Newtons on the surface at which a fingertip counts as touching it (:func:`touch_down`)."""
TOUCH_STEP = 0.0005
TOUCH_ABOVE = 0.004
"""Metres over a low grasp's plan where the hand stops before :func:`touch_down` (the servos sag onto it)."""
TOUCH_HOLD_S = 0.05
PRESS_LIMIT = 10.0
"""Newtons the open fingers may press on what the object stands on when they close (:func:`ease_off`)."""
EASE_STEP = 0.001
EASE_STEPS = 10
"""Steps of :data:`EASE_STEP` the hand rises at most to ease off what the object stands on."""
STRAIGHT_DOWN = 0.95
"""Cosine from the vertical within which a grasp counts as taken straight down."""
DROP = 0.002
"""Metres above the surface where a placed object is let go."""
YAWS = (0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0, 135.0, -135.0, 180.0)
"""Degrees the held object may be turned about the vertical when set down, in the order tried."""
RELEASE_S = 0.4
LEVEL_TOLERANCE_DEG = 3.0
"""Degrees a held object may lean from how it stood before it is levelled to be set down."""
SET_DOWN_SETTLE_S = 0.2
"""Seconds the arm holds still where it sets an object down before its tcp is corrected."""


def grasp(
    ctx: SkillContext,
    name: str,
    *,
    at: str | None = None,
    mode: str = "auto",
    height: float | None = None,
    extra_touch: AbstractSet[int] = frozenset(),
    then: FollowThrough | None = None,
) -> Iterator[Move]:
    """Approach ``name``, close on it and record it as held (the hand ends at the grasp pose).
    The fingers may touch ``name`` and ``extra_touch`` (what it stands in) on the way in."""
    if ctx.hand.held is not None:
        raise SkillFailure(f"the hand already holds {ctx.hand.held.name!r}; put it down first")
    toward = entry_direction(ctx, name)
    after = tool_follow_through(ctx, name)
    step = ctx.next_step
    above = None  # taken high enough that the hole it goes into next seats it
    if height is None and at is None and isinstance(step, InsertIntoSpec) and step.object == name:
        above = insertion_grasp(ctx, step)
    exact = isinstance(ctx.next_step, PositionOverSpec)  # the pose it goes to, not one of its choices
    try:
        plan = plan_grasp(
            ctx, name, at=at, mode=mode, height=height, above=above, toward=toward, then=then, later=after, exact=exact
        )
    except SkillFailure:
        if after is None:
            raise
        # no grasp leaves the next step's pose in reach: the next step turns what it holds as it can
        plan = plan_grasp(ctx, name, at=at, mode=mode, height=height, above=above, toward=toward, then=then)
    exclude = ctx.scene.bodies(name)
    if ctx.hand.gripper != OPEN:
        yield ctx.grip(OPEN, 0.3)
    yield from transit(ctx, plan.approach[0], plan.rot, exclude=exclude, what=f"the approach to {name!r}")

    support = support_of(ctx, name)
    with ctx.hand.touching(exclude | set(extra_touch) | support):
        for point in plan.approach[1:]:
            yield ctx.move(point, plan.rot, speed=APPROACH_SPEED, what=f"the approach to {name!r}")
        guarded = bool(support) and _lying_low(ctx, name, plan)
        stop = plan.pos + TOUCH_ABOVE * UP if guarded else plan.pos
        yield ctx.move(stop, plan.rot, speed=APPROACH_SPEED, what=f"the grasp of {name!r}")
        # the servos stop a few millimetres short under gravity: centred between the fingers before
        # they close (or the first finger to arrive pushes a small object over); and where the sag
        # took the open fingertips down to what they close over (a rack's top, whose edges would
        # stop them), or would leave it held too low for the hole it goes into next (let go above
        # its seat there, it tips), up to the planned height too
        sunk = partial(_fingertips_sunk, ctx, name, plan)
        low = partial(_held_too_low, ctx, name, above)
        yield from settle_hand(
            ctx, GRASP_SETTLE_S, what=f"the grasp of {name!r}", required=False, vertical=lambda: sunk() or low()
        )
        if guarded:
            yield from touch_down(ctx, name, support)
        else:
            yield from ease_off(ctx, name, support)
        yield ctx.grip(CLOSED, CLOSE_S)
    ctx.hand.attach(name)


def _lying_low(ctx: SkillContext, name: str, plan: Grasp) -> bool:
    """Whether ``plan`` takes ``name`` straight down with the fingertips just over the surface it
    lies on (a rod, a spatula): the grasp is made by :func:`touch_down`."""
    lift = plan.pos[2] - ctx.scene.shape(name).bottom
    return bool(plan.rot[2, 2] <= -STRAIGHT_DOWN and lift <= FINGERTIP_LIFT + TOUCH_ABOVE)


def touch_down(ctx: SkillContext, name: str, support: AbstractSet[int]) -> Iterator[Move]:
    """Lower the hand in small steps until the fingertips touch ``support`` (what ``name`` lies on),
    lightly: a guarded move, as a real arm makes with its force sensing. Short of the surface the
    fingers close above a thin object's middle and squeeze it out; a servo that sagged onto it
    presses too hard to close (friction there holds the fingers open)."""
    for _ in range(round((FINGERTIP_LIFT + 2 * TOUCH_ABOVE) / TOUCH_STEP)):
        if ctx.world.robot_force(support) > TOUCH_FORCE:
            return
        try:
            move = ctx.move(
                ctx.hand.pos - TOUCH_STEP * UP, ctx.hand.rot, speed=FINE_SPEED, what=f"the grasp of {name!r}"
            )
        except SkillFailure:
            return
        yield move
        yield ctx.hold(TOUCH_HOLD_S)


def ease_off(ctx: SkillContext, name: str, support: AbstractSet[int]) -> Iterator[Move]:
    """Raise the hand in small steps while its fingers press on ``support`` (what ``name`` stands on)
    harder than :data:`PRESS_LIMIT`: a tilted hand's fingertip corners planned just over the bench
    sag onto it, and friction there at 80-100 N holds the fingers open."""
    for _ in range(EASE_STEPS):
        if ctx.world.robot_force(support) <= PRESS_LIMIT:
            return
        try:
            move = ctx.move(
                ctx.hand.pos + EASE_STEP * UP, ctx.hand.rot, speed=FINE_SPEED, what=f"the grasp of {name!r}"
            )
        except SkillFailure:
            return
        yield move
        yield ctx.hold(TOUCH_HOLD_S)


def _held_too_low(ctx: SkillContext, name: str, above: float | None) -> bool:
    """Whether the tcp, as it stands, is less than ``above`` (less the slip room allowed) over
    ``name``'s origin: the hole it goes into next would stop the fingers before it is seated."""
    if above is None:
        return False
    return bool(ctx.world.tcp_position()[2] - ctx.world.position(name)[2] < above - SLIP_ROOM)


def _fingertips_sunk(ctx: SkillContext, name: str, plan: Grasp) -> bool:
    """Whether the open fingertips of a straight-down grasp hang below the top of what they close
    over, beside it (over a rack's hole, touching nothing but the object): closing, they would run
    into its edge. Resting on it, they slide over it."""
    approach = plan.rot[:, 2]
    if approach[2] > -STRAIGHT_DOWN:
        return False
    tips = ctx.world.tcp_position() + ctx.robot.gripper.fingertip * approach
    under = closed_over(ctx, name, tips, below=float(plan.pos[2]))
    return bool(tips[2] < under) and not ctx.world.robot_contacts() - ctx.scene.bodies(name)


def entry_direction(ctx: SkillContext, name: str) -> np.ndarray | None:
    """If the program's next step puts ``name`` into an enclosure (a shelf under a roof), the
    horizontal direction into it: the grasp should let the hand point that way."""
    step = ctx.next_step
    target = getattr(step, "target", None)
    if step is None or getattr(step, "object", None) != name or target is None:
        return None

    point = resolve_target(ctx, target, surface=False)
    skip = ctx.scene.bodies(name)
    if not ctx.plan.covered(point, skip):
        return None
    direction, _ = ctx.scene.way_out(point + 0.01 * UP, skip, prefer=ctx.base - point)
    return -direction


def tool_follow_through(ctx: SkillContext, name: str) -> FollowThrough | None:
    """If the program's next step holds ``name``'s working point over a target (``position_over``)
    or stands it upright in a holder (``insert_into``), the hand's poses for it, as grasped: a grasp
    the arm can lift and take there is preferred."""
    step = ctx.next_step
    if isinstance(step, InsertIntoSpec) and step.object == name and step.axis == "auto":
        return _upright_follow_through(ctx, step)
    if not isinstance(step, PositionOverSpec) or step.object != name:
        return None
    site = step.point or (f"{name}/tip" if "tip" in ctx.scene.semantics(name).get("sites", []) else None)
    point = ctx.world.position(site) if site else ctx.world.position(name)
    goal = resolve_target(ctx, step.target, surface=False) + step.height * UP

    def then(g: Grasp) -> list[tuple[np.ndarray, np.ndarray]]:
        local = g.rot.T @ (point - g.pos)
        return [(goal - g.rot @ local, g.rot)]

    return then


def _upright_follow_through(ctx: SkillContext, step: InsertIntoSpec) -> FollowThrough:
    """The entry pose over the holder for a grasp, the object turned upright with the hand pointing
    as far away from the base as the turn allows (how a short arm reaches out and down)."""
    final, rise = insertion(ctx, step, ctx.scene.bodies(step.object))
    site = ctx.world.position(step.target)
    out = horizontal(site - ctx.base)
    obj_pos, obj_rot = ctx.world.position(step.object), ctx.world.rotation(step.object)

    def then(g: Grasp) -> list[tuple[np.ndarray, np.ndarray]]:
        held = Held(step.object, g.rot.T @ (obj_pos - g.pos), g.rot.T @ obj_rot)
        rot = max(upright_rotations(held, g.rot), key=lambda r: float(r[:, 2] @ out - r[2, 2]))
        return [(final(rot, held) + rise * UP, rot)]

    return then


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
        # over the spot planned; left pressed on the surface by the servo's sag (let go in the air,
        # the fingers springing open throw a light object), unless the fingers press on something
        # too (its fingertips reach below the object's base): then raised to the plan
        held = ctx.scene.bodies(name)
        yield from settle_hand(
            ctx,
            SET_DOWN_SETTLE_S,
            what=f"setting {name!r} down",
            vertical=lambda: bool(ctx.world.robot_contacts() - held),
        )
        yield ctx.grip(OPEN, RELEASE_S)
        ctx.hand.held = None
        with ctx.hand.touching(held):
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
        held = ctx.hand.held
        assert held is not None
        level = leveled(ctx, name, ctx.hand.rot @ held.rot)
        for yaw in YAWS:  # turning about the vertical keeps the object level
            turn = axis_rotation(UP, np.deg2rad(yaw))
            obj_rot = turn @ ctx.hand.rot @ held.rot if level is None else turn @ level
            tool_pos, tool_rot = ctx.hand.tool_for(name, point + lift * UP, obj_rot)
            above = tool_pos + (0.012 if covered else 0.05) * UP
            if ctx.plan.margin(
                [(above, tool_rot), (tool_pos, tool_rot)], touch=support
            ) is not None and ctx.plan.can_reach(above, tool_rot):
                return tool_pos, tool_rot, above
    return None


def leveled(ctx: SkillContext, name: str, rot: np.ndarray) -> np.ndarray | None:
    """``name``'s rotation ``rot`` (as held) turned to stand as it stood at the start, where it is
    held tilted by more than :data:`LEVEL_TOLERANCE_DEG` (a dish pinched at its rim, the near side
    lifted): set down as held, it lands on an edge. None when it is held level enough."""
    up = rot @ ctx.start_up[name]
    tilt = float(np.degrees(np.arccos(np.clip(up @ UP, -1.0, 1.0))))
    if tilt <= LEVEL_TOLERANCE_DEG:
        return None
    axis = np.cross(up, UP)
    return axis_rotation(axis / np.linalg.norm(axis), np.deg2rad(tilt)) @ rot


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
