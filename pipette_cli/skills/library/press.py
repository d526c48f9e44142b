"""``press``: push a button along its face's normal with the closed fingertips."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from pipette_cli.skills.frames import UP, down_frame, pitched_frame, tool_frame
from pipette_cli.skills.motions import transit
from pipette_cli.skills.moves import CLOSED, FINE_SPEED, Move, SkillFailure
from pipette_cli.skills.runtime import SkillContext, skill
from pipette_cli.specs.expert import PressSpec

STANDOFFS = (0.08, 0.05, 0.03)
"""Metres in front of the button where the approach starts (less where the arm is cramped)."""


@skill(PressSpec)
def press(ctx: SkillContext, step: PressSpec) -> Iterator[Move]:
    if ctx.hand.held is not None:
        raise SkillFailure(f"the hand holds {ctx.hand.held.name!r}; put it down before pressing")
    owner = step.button.split("/", 1)[0]
    site = ctx.world.position(step.button)
    panel = int(ctx.world.model.site_bodyid[ctx.world.site_id(step.button)])
    normal = ctx.scene.face_normal(site, owner, prefer=ctx.base - site)
    fingers = ctx.robot.gripper
    if normal[2] > 0.9:  # a button on a top face: fingertips straight down onto it
        frames = [down_frame(np.array([1.0, 0.0, 0.0]))]
    else:  # a front face: fingertips first, or the side of the fingers with the hand pitched down or held sideways
        frames = [pitched_frame(-normal, pitch) for pitch in (0.0, 30.0, 45.0, 60.0, 75.0, 90.0, 105.0, 120.0)]
        along = np.cross(normal, UP)
        for s in (1.0, -1.0):
            for tilt in (0.0, 45.0):
                a = np.cos(np.deg2rad(tilt)) * s * along - np.sin(np.deg2rad(tilt)) * UP
                frames.append(tool_frame(a, np.cross(normal, a)))
    candidates = [(rot, standoff) for standoff in STANDOFFS for rot in frames]

    def contact(candidate: tuple[np.ndarray, float]) -> np.ndarray:
        """Tcp position where the fingers touch the button's face: the fingertips and the fingers'
        sides reach this far along the push from the tcp."""
        rot = candidate[0]
        reach = fingers.fingertip * max(0.0, float(rot[:, 2] @ -normal)) + 0.5 * fingers.finger_thickness * abs(
            float(rot[:, 0] @ normal)
        )
        return site + reach * normal

    def poses(candidate: tuple[np.ndarray, float]) -> list[tuple[np.ndarray, np.ndarray]]:
        rot, standoff = candidate
        touch = contact(candidate)
        return [(touch + standoff * normal, rot), (touch - step.depth * normal, rot)]

    chosen = ctx.plan.choose(candidates, poses, via=lambda c: (contact(c) + c[1] * normal, c[0]), touch={panel})
    if chosen is None:
        raise SkillFailure(f"no reachable way to press {step.button!r} along its face")
    rot, standoff = chosen
    touch = contact(chosen)
    front, pushed = touch + standoff * normal, touch - step.depth * normal
    if ctx.hand.gripper != CLOSED:
        yield ctx.grip(CLOSED, 0.3)
    yield from transit(ctx, front, rot, what=f"the approach to {step.button!r}")
    with ctx.hand.touching({panel}):
        yield ctx.move(touch + 0.01 * normal, rot, speed=FINE_SPEED * 2, what=f"pressing {step.button!r}")
        yield ctx.move(pushed, rot, speed=FINE_SPEED, what=f"pressing {step.button!r}")
        if step.hold_s:
            yield ctx.hold(step.hold_s)
        yield ctx.move(front, rot, speed=FINE_SPEED * 2, what=f"backing off {step.button!r}")
