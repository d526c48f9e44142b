"""``position_over`` and ``tilt``: use what the hand holds as a tool.

``position_over`` brings a point of the held tool (its ``tip`` site by default: a pipette's tip,
a loop's end) to a height above a target and holds it there, the tool kept as it was grasped (turned
about the vertical where the arm cannot get there otherwise).
``tilt`` turns the held object about the horizontal axis across the hand (pouring) and back.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from pipette_cli.skills.frames import UP, axis_rotation
from pipette_cli.skills.handling import YAWS
from pipette_cli.skills.motions import follow, transit
from pipette_cli.skills.moves import APPROACH_SPEED, Move, SkillFailure
from pipette_cli.skills.runtime import SkillContext, skill
from pipette_cli.skills.targets import resolve_target
from pipette_cli.specs.expert import PositionOverSpec, TiltSpec


def tool_point(ctx: SkillContext, name: str, point: str | None) -> np.ndarray:
    """The held tool's working point in the tcp frame: ``point``, else its ``tip`` site, else its origin."""
    held = ctx.hand.holding(name)
    if point is None and "tip" in ctx.scene.semantics(name).get("sites", []):
        point = f"{name}/tip"
    if point is None:
        return held.pos
    tcp_pos, tcp_rot = ctx.world.tcp_position(), ctx.world.tcp_rotation()
    return tcp_rot.T @ (ctx.world.position(point) - tcp_pos)


@skill(PositionOverSpec)
def position_over(ctx: SkillContext, step: PositionOverSpec) -> Iterator[Move]:
    offset = tool_point(ctx, step.object, step.point)
    target = resolve_target(ctx, step.target, surface=False)
    goal = target + step.height * UP
    # as grasped where the arm gets there, else turned about the vertical (still level)
    rotations = [axis_rotation(UP, np.deg2rad(yaw)) @ ctx.hand.rot for yaw in YAWS]
    for rot in rotations:
        legs = ctx.plan.path(goal - rot @ offset, rot)
        if legs is not None:
            yield from follow(ctx, legs)
            break
    else:  # none: the refusal names the pose as grasped
        yield from transit(
            ctx, goal - ctx.hand.rot @ offset, ctx.hand.rot, what=f"bringing {step.object!r} over {step.target!r}"
        )
    ctx.hand.check_holding(step.object)
    if step.hold_s:
        yield ctx.hold(step.hold_s)


@skill(TiltSpec)
def tilt(ctx: SkillContext, step: TiltSpec) -> Iterator[Move]:
    ctx.hand.holding(step.object)
    axis = ctx.hand.rot[:, 1].copy()  # across the hand: the fingers' closing direction
    axis[2] = 0.0
    if np.linalg.norm(axis) < 1e-6:
        raise SkillFailure(f"cannot tilt {step.object!r}: the hand's closing direction is vertical")
    axis /= np.linalg.norm(axis)
    start_pos, start_rot = ctx.hand.pos.copy(), ctx.hand.rot.copy()
    turned = axis_rotation(axis, np.deg2rad(step.angle_deg)) @ start_rot
    yield ctx.move(start_pos, turned, speed=APPROACH_SPEED, what=f"tilting {step.object!r}")
    ctx.hand.check_holding(step.object)
    if step.hold_s:
        yield ctx.hold(step.hold_s)
    if step.back:
        yield ctx.move(start_pos, start_rot, speed=APPROACH_SPEED, what=f"tilting {step.object!r} back")
