"""``pick`` and ``remove_from``: grasp an object and take it up, or out of what holds it."""

from __future__ import annotations

from collections.abc import Iterator
from collections.abc import Set as AbstractSet
from functools import partial

import numpy as np

from pipette_cli.skills.frames import UP, horizontal
from pipette_cli.skills.grasp import FollowThrough, Grasp, closed_over, plan_grasp, semantics, support_of
from pipette_cli.skills.library.place import insertion, put_down, resolve_target, upright_rotations
from pipette_cli.skills.motions import leave_enclosure, lift_clear, settle_hand, transit
from pipette_cli.skills.moves import APPROACH_SPEED, CLOSED, OPEN, Held, Move, SkillFailure
from pipette_cli.skills.runtime import SkillContext, skill
from pipette_cli.specs.expert import InsertIntoSpec, PickSpec, PositionOverSpec, RemoveFromSpec

SETTLE_S = 0.25
"""Seconds to let the arm's servos catch up with the grasp pose before closing."""
CLOSE_S = 0.5
STRAIGHT_DOWN = 0.95
"""Cosine from the vertical within which a grasp counts as taken straight down."""


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
    exact = isinstance(ctx.next_step, PositionOverSpec)  # the pose it goes to, not one of its choices
    try:
        plan = plan_grasp(
            ctx, name, at=at, mode=mode, height=height, toward=toward, then=then, later=after, exact=exact
        )
    except SkillFailure:
        if after is None:
            raise
        # no grasp leaves the next step's pose in reach: the next step turns what it holds as it can
        plan = plan_grasp(ctx, name, at=at, mode=mode, height=height, toward=toward, then=then)
    exclude = ctx.scene.bodies(name)
    if ctx.hand.gripper != OPEN:
        yield ctx.grip(OPEN, 0.3)
    yield from transit(ctx, plan.approach[0], plan.rot, exclude=exclude, what=f"the approach to {name!r}")

    with ctx.hand.touching(exclude | set(extra_touch) | support_of(ctx, name)):
        for point in plan.approach[1:]:
            yield ctx.move(point, plan.rot, speed=APPROACH_SPEED, what=f"the approach to {name!r}")
        yield ctx.move(plan.pos, plan.rot, speed=APPROACH_SPEED, what=f"the grasp of {name!r}")
        # the servos stop a few millimetres short under gravity: centred between the fingers before
        # they close (or the first finger to arrive pushes a small object over); and where the sag
        # took the open fingertips down to what they close over (a rack's top, whose edges would
        # stop them), up to the planned height too, which clears it
        sunk = partial(_fingertips_sunk, ctx, name, plan)
        yield from settle_hand(ctx, SETTLE_S, what=f"the grasp of {name!r}", required=False, vertical=sunk)
        yield ctx.grip(CLOSED, CLOSE_S)
    ctx.hand.attach(name)


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
    site = step.point or (f"{name}/tip" if "tip" in semantics(ctx, name).get("sites", []) else None)
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


@skill(PickSpec)
def pick(ctx: SkillContext, step: PickSpec) -> Iterator[Move]:
    yield from grasp(ctx, step.object, at=step.at, mode=step.grasp, height=step.height)
    yield from lift_clear(ctx, step.lift, required=True)
    ctx.hand.check_holding(step.object)
    if step.hold_s:
        yield ctx.hold(step.hold_s)


@skill(RemoveFromSpec)
def remove_from(ctx: SkillContext, step: RemoveFromSpec) -> Iterator[Move]:
    source = ctx.scene.bodies(step.source)
    yield from grasp(ctx, step.object, at=step.at, extra_touch=source)
    with ctx.hand.touching(source):
        yield from lift_clear(ctx, 0.03)
        ctx.hand.check_holding(step.object)
        if ctx.plan.covered(ctx.hand.pos, ctx.hand.held_bodies()):
            yield from leave_enclosure(ctx, ctx.hand.held_bodies())
    ctx.hand.check_holding(step.object)
    if step.to == "hold":
        yield ctx.hold(step.hold_s)
        return

    if step.to == "bench":
        shape = ctx.scene.shape(step.object)
        spot = ctx.scene.free_spot(
            ctx.start[step.object],
            float(np.max(shape.world_half()[:2])) + 0.02,
            ctx.hand.held_bodies(),
            (ctx.robot.min_reach, ctx.robot.reach),
            ctx.base,
            ctx.robot.base_height,
        )
        if spot is None:
            raise SkillFailure(f"no free spot on the bench near {step.source!r} to set {step.object!r} down")
        target = spot
    else:
        target = resolve_target(ctx, step.to)
    yield from put_down(ctx, step.object, target)
