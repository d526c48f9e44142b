"""Putting what the hand holds into a hole (a rack's hole, a box's cell, a rotor well, an instrument's
slot), measured against the hole rather than against the pose the arm was commanded to.

A position servo under gravity stands a few millimetres from its command, and a tube in an 11.5 mm
hole has a third of a millimetre to spare: the hand is lined up by where the tcp *stands*
(:func:`line_up`), and the moves into the hole carry the standing error measured there. The hand
goes no lower than its closed fingers allow over what surrounds the hole (:func:`finger_floor`): an
object held low (a tube taken by its top 17 mm out of a rotor well hangs only a little below the
fingertips) goes in as far as that, is let go standing in the hole, and is taken again higher up
and pushed to its seat (:func:`push_home`). Letting go first eases off the downward push (fingers
pressed onto a rack's top do not open), then opens, then backs off (:func:`let_go`): what stands in
the hole is not dragged up with the fingers.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Generator, Iterator
from collections.abc import Set as AbstractSet

import numpy as np

from pipette_cli.skills.frames import UP, rotation_angle
from pipette_cli.skills.handling import RELEASE_S, grasp
from pipette_cli.skills.motions import back_off
from pipette_cli.skills.moves import FINE_SPEED, OPEN, Move, fmt
from pipette_cli.skills.runtime import SkillContext
from pipette_cli.skills.targets import finger_floor, opening_floor, seat_gap

log = logging.getLogger(__name__)

LINE_UP_TOLERANCE = 0.0007
"""Metres the tcp, as it stands, may be from the pose that puts the object over the hole."""
LINE_UP_TRIES = 3
EASE_OFF = 0.001
"""Metres over where the tcp stands that the hand is commanded to before the fingers open."""
MAX_OPENING_RISE = 0.006
"""Metres at most the hand lifts what it holds in a hole for its fingers to open clear of the hole's surround."""
REGRASP_RETREAT = 0.02
"""Metres the empty hand lifts after letting go of an object it will take again higher up."""


def standing_error(ctx: SkillContext) -> np.ndarray:
    """Where the tcp was commanded minus where it stands (an outstretched arm sags short of its command)."""
    return ctx.hand.pos - ctx.world.tcp_position()


def line_up(
    ctx: SkillContext, goal: Callable[[], tuple[np.ndarray, np.ndarray]], *, what: str
) -> Generator[Move, None, np.ndarray]:
    """Bring the tcp, as it stands, to ``goal()`` (recomputed after every move: the object may turn
    or slip in the grasp), moving the command by the error measured, up to :data:`LINE_UP_TRIES`
    times; returns the tool rotation of the last goal."""
    pos, rot = goal()
    for _ in range(LINE_UP_TRIES):
        error = pos - ctx.world.tcp_position()
        if np.linalg.norm(error) < LINE_UP_TOLERANCE and rotation_angle(ctx.hand.rot, rot) < np.deg2rad(0.5):
            break
        log.debug("%s at t=%.2f: correcting by %s", what, ctx.world.time, fmt(error))
        yield ctx.move(ctx.hand.pos + error, rot, speed=FINE_SPEED, what=what)
        yield ctx.hold(0.2)
        pos, rot = goal()
    return rot


def let_go(ctx: SkillContext, name: str, offset: np.ndarray | None, retreat: float) -> Iterator[Move]:
    """Open the hand on ``name`` standing in its hole and back off, without dragging it. With the
    standing error ``offset`` (the fingertips over what surrounds the hole), the command is first
    brought to where the tcp stands, so the hand no longer pushes the fingertips down and they open
    freely; without, the sag keeps pressing the object onto its seat, which holds it as they open."""
    stands = ctx.world.tcp_position()
    eased = None if offset is None else stands + offset + EASE_OFF * UP
    rise = opening_floor(ctx, name, stands, ctx.hand.rot) - float(stands[2])
    if rise > 0.0:
        # the opening fingertips would land on what surrounds the hole (pressed there at 50-70 N they
        # stall): lifted clear first, what they hold with them, no more than it can drop back in
        log.debug("letting go of %s: the hand raised %.1f mm for the fingers to open", name, rise * 1000)
        base = ctx.hand.pos if eased is None else eased
        eased = base + min(rise, MAX_OPENING_RISE) * UP
    if eased is not None and np.linalg.norm(eased - ctx.hand.pos) > 0.0005:
        yield ctx.move(eased, ctx.hand.rot, speed=FINE_SPEED, what=f"easing off {name!r}", check=False)
    yield ctx.grip(OPEN, RELEASE_S)
    ctx.hand.held = None
    with ctx.hand.touching(ctx.scene.bodies(name)):
        yield from back_off(ctx, retreat)


def push_home(
    ctx: SkillContext, name: str, site: np.ndarray, holder: AbstractSet[int], retreat: float
) -> Iterator[Move]:
    """Take ``name``, standing above its seat in the hole at ``site``, again higher up (so the
    fingertips stay above the hole's surround all the way down), push it onto its seat and let go."""
    gap = seat_gap(ctx, name, site)
    rot = ctx.hand.rot
    floor = finger_floor(ctx, name, ctx.world.position(name), rot)
    height = floor + gap - float(ctx.world.position(name)[2]) + 0.001
    log.debug("push %s home: %.1f mm above its seat, taken again %.1f mm up", name, gap * 1000, height * 1000)
    yield from grasp(ctx, name, height=height, extra_touch=holder)
    offset = standing_error(ctx)
    floor = finger_floor(ctx, name, ctx.world.tcp_position(), ctx.hand.rot)
    goal = ctx.world.tcp_position() - (seat_gap(ctx, name, site) - 0.001) * UP
    goal[2] = max(goal[2], floor)
    with ctx.hand.touching(set(holder)):
        yield ctx.move(goal + offset, ctx.hand.rot, speed=FINE_SPEED, what=f"pushing {name!r} home")
        yield ctx.hold(0.2)
        yield from let_go(ctx, name, offset, retreat)
