"""Motions the skills share, each a few moves: a transit along the planner's path, a lift clear of
what is overhead, backing out of an enclosure, settling the hand on its planned pose, withdrawing.

They command the hand through the skill context (:mod:`.runtime`) and ask the planner
(``ctx.plan``) where it can go; skills (:mod:`.library`) import them, never each other.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from collections.abc import Set as AbstractSet

import numpy as np

from pipette_cli.skills.frames import UP
from pipette_cli.skills.moves import APPROACH_SPEED, FINE_SPEED, FREE_TOLERANCE, Leg, Move, SkillFailure, fmt
from pipette_cli.skills.runtime import SkillContext

SETTLE_TOLERANCE = 0.001
"""Metres the tcp may stand from its planned pose after :func:`settle_hand`."""
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
    """Go to ``pos``/``rot`` over whatever stands in between (see :meth:`Planner.path <pipette_cli.skills.transit.Planner.path>`)."""
    legs = ctx.plan.path(pos, rot, exclude=exclude, radius=radius)
    if legs is None:
        raise SkillFailure(
            f"{what}: no path to {fmt(np.asarray(pos))} within the {ctx.robot.name}'s reach "
            "that touches nothing on the way"
        )
    yield from follow(ctx, legs)


def follow(ctx: SkillContext, legs: list[Leg]) -> Iterator[Move]:
    """The moves along legs the planner found (:meth:`~pipette_cli.skills.transit.Planner.path`)."""
    for leg in legs:
        yield ctx.planned(leg.pos, leg.rot, leg.q, speed=leg.speed, straight=leg.straight, joints=leg.joints)


def leave_enclosure(ctx: SkillContext, exclude: set[int]) -> Iterator[Move]:
    """Back the hand (and what it holds) out of whatever covers it, level, toward the robot."""
    direction, mouth = ctx.scene.way_out(
        ctx.hand.pos, set(exclude) | ctx.hand.held_bodies(), prefer=ctx.base - ctx.hand.pos
    )
    start = Leg(ctx.hand.pos, ctx.hand.rot, ctx.hand.q, APPROACH_SPEED)
    for extra in (0.05, 0.03, 0.08):
        out = ctx.hand.pos + direction * (mouth + extra)
        out[2] += 0.01
        leg = ctx.plan.leg(start, out, ctx.hand.rot, APPROACH_SPEED, FREE_TOLERANCE, keep=True)
        if leg is not None:
            yield ctx.planned(leg.pos, leg.rot, leg.q, speed=APPROACH_SPEED)
            return
    raise SkillFailure(f"no way out of the enclosure from {fmt(ctx.hand.pos)} that touches nothing")


def lift_clear(
    ctx: SkillContext, height: float, exclude: AbstractSet[int] = frozenset(), *, required: bool = False
) -> Iterator[Move]:
    """Lift by ``height``: less where something is overhead or the arm cannot go higher (unless
    ``required``, when a lift the arm cannot make fails the skill)."""
    room = ctx.scene.clearance_above(ctx.hand.pos + 0.02 * UP, set(exclude) | ctx.hand.held_bodies()) + 0.02
    up = min(height, max(0.0, room - 0.05))
    if up <= 0.003:
        return
    for fraction in (1.0, 0.6, 0.3):
        try:
            move = ctx.move(ctx.hand.pos + fraction * up * UP, speed=APPROACH_SPEED, what="the lift")
        except SkillFailure:
            if required and fraction == 0.3:
                raise
            continue
        yield move
        return


def settle_hand(
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
    goal, rot = ctx.hand.pos.copy(), ctx.hand.rot
    yield ctx.hold(seconds)
    raise_too = vertical is not None and vertical()
    for _ in range(SETTLE_TRIES):
        error = goal - ctx.world.tcp_position()
        error[2] = max(error[2], 0.0) if raise_too else 0.0
        if float(np.linalg.norm(error)) < SETTLE_TOLERANCE:
            break
        try:
            move = ctx.move(ctx.hand.pos + error, rot, speed=FINE_SPEED, what=what)
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
            move = ctx.move(
                ctx.hand.pos - fraction * distance * ctx.hand.rot[:, 2], speed=APPROACH_SPEED, what="backing off"
            )
        except SkillFailure:
            continue
        yield move
        return


def back_off(ctx: SkillContext, distance: float) -> Iterator[Move]:
    """Withdraw the empty hand: along its approach axis, out of an enclosure, then up."""
    if distance <= 0:
        return
    yield from withdraw(ctx, 0.03)
    if ctx.plan.covered(ctx.hand.pos, set()):
        yield from leave_enclosure(ctx, set())
    yield from lift_clear(ctx, distance)
