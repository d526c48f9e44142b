"""``pick`` and ``remove_from``: grasp an object and take it up, or out of what holds it."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from pipette_cli.skills.handling import grasp, put_down
from pipette_cli.skills.motions import leave_enclosure, lift_clear
from pipette_cli.skills.moves import Move, SkillFailure
from pipette_cli.skills.runtime import SkillContext, skill
from pipette_cli.skills.targets import resolve_target
from pipette_cli.specs.expert import PickSpec, RemoveFromSpec


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
