"""``wait`` and ``retreat``: hold still, or let go and back away (home, with ``home``)."""

from __future__ import annotations

from collections.abc import Iterator

from pipette_cli.skills.motions import back_off, transit
from pipette_cli.skills.moves import OPEN, TRANSIT_SPEED, Move
from pipette_cli.skills.runtime import SkillContext, skill
from pipette_cli.specs.expert import RetreatSpec, WaitSpec


@skill(WaitSpec)
def wait(ctx: SkillContext, step: WaitSpec) -> Iterator[Move]:
    yield ctx.hold(step.seconds)


@skill(RetreatSpec)
def retreat(ctx: SkillContext, step: RetreatSpec) -> Iterator[Move]:

    if ctx.hand.gripper != OPEN:
        yield ctx.grip(OPEN, 0.4)
        ctx.hand.held = None
    yield from back_off(ctx, step.distance)
    if step.home:
        pos, rot = ctx.ik.tool_pose(ctx.robot.home())
        yield from transit(ctx, pos, rot, what="the way home")
        yield ctx.move(pos, rot, speed=TRANSIT_SPEED, what="the home pose")
    if step.hold_s:
        yield ctx.hold(step.hold_s)
