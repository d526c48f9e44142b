"""Grasp candidates from an object's shape and semantics: where the fingers can close on it and how
the hand is turned, before the arm's reach decides between them (:func:`~pipette_cli.skills.grasp.plan_grasp`).

Each builder returns :class:`Grasp` s in the order they should be tried: around an upright
object's axis from above (pitched toward the robot where straight down is out of reach), across a
lying tool, in front of a handle bar, at a named site from the side, or pinching a flat object's
rim.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipette_cli.sim.robots import FINGER_FRICTION
from pipette_cli.skills.frames import UP, axis_rotation, down_frame, horizontal, pitched_frame, tool_frame
from pipette_cli.skills.grip import FINGERTIP_LIFT, GRIP_MARGIN, PALM_MARGIN, ROUND
from pipette_cli.skills.moves import SkillFailure
from pipette_cli.skills.runtime import SkillContext
from pipette_cli.skills.scene import Shape

PINCH_PITCHES = (30.0, 20.0, 40.0, 10.0)
"""Degrees below the horizon a pinching hand points, in the order tried (low fits under a shelf)."""
PINCH_TURNS = (35.0, -35.0)
"""Degrees the pinch direction turns from facing the robot, in the order tried."""
CORNER_ROOM = 0.001
"""Metres a pinching hand's lowest fingertip corner keeps over what the object stands on."""
PINCH_DROP = 0.08
"""Metres above the rim a pinch from straight above starts."""
TOP_PITCHES = (90.0, 75.0, 60.0, 50.0, 40.0)
BAR_GAP = 0.02
"""Metres of room under a handle bar that a finger taking it from in front needs."""
SITE_SLACK = 0.03
"""Metres a grip geom's centre may lie from the named site it is found at."""


@dataclass(frozen=True)
class Grasp:
    """Tcp pose at the grasp, the approach path into it, and what kind of grasp it is."""

    kind: str
    pos: np.ndarray
    rot: np.ndarray
    approach: list[np.ndarray]
    """Tcp positions to pass through before ``pos`` (outermost first)."""
    width: float


def _fingertips_clear(ctx: SkillContext, name: str, shape: Shape) -> float:
    """Lowest tcp height for a straight-down grasp about an upright object: its fingertips above
    what the open fingers close over (the bench, or the rack or holder it stands in)."""
    around = closed_over(ctx, name, ctx.world.position(name), below=shape.top)
    return max(shape.bottom, around) + FINGERTIP_LIFT


def closed_over(ctx: SkillContext, name: str, point: np.ndarray, below: float) -> float:
    """Highest surface the open fingers sweep over as they close on ``name`` about ``point`` (the
    bench, or the rack or holder it stands in), looking down from height ``below``."""
    reach = ctx.robot.gripper.max_opening / 2
    return ctx.scene.corridor_top(point, point, reach, ctx.scene.bodies(name), below=below)


def grasp_point(
    ctx: SkillContext,
    name: str,
    shape: Shape,
    at: str | None,
    height: float | None,
    lying: bool,
    above: float | None = None,
) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """Grasp point, closing direction, the object's width across the fingers there, and whether it
    is round there (the hand may close along any horizontal: a tube, a neck; not a handle bar).
    ``above``: an upright object is taken at least that high over its origin (what a hole it is put
    into next needs), as the hand allows."""
    sem = ctx.scene.semantics(name)
    base = ctx.world.position(name)
    if at is not None:
        point = ctx.world.position(at)
        return point, *_local_closing(ctx, name, point, shape, site=at)
    if lying:
        long_axis = horizontal(shape.long_axis())
        point = ctx.world.position(f"{name}/grasp") if "grasp" in sem.get("sites", []) else shape.center.copy()
        point[2] = max(point[2], shape.bottom + FINGERTIP_LIFT)
        closing = np.array([-long_axis[1], long_axis[0], 0.0])
        width = float(2 * np.abs(closing @ shape.axes) @ shape.half)
        return point, closing, width, False
    top = shape.top
    if height is not None:
        z = base[2] + height
    elif "grasp" in sem.get("sites", []):
        z = float(ctx.world.position(f"{name}/grasp")[2])
    else:
        z = shape.bottom + 0.6 * (top - shape.bottom)
    if above is not None:
        z = max(z, base[2] + above)
    palm = ctx.robot.gripper.finger_depth - PALM_MARGIN
    z = max(z, top - palm, _fingertips_clear(ctx, name, shape))
    z = min(z, top - 0.004)
    slab = _slab(ctx, name, shape, z)
    point = np.array([slab.center[0], slab.center[1], z])
    radial = horizontal(point - ctx.base)
    closing, width = _narrow_side(slab, radial, shape.vertical_axis())
    return point, closing, width, bool(np.allclose(closing, radial))


def _slab(ctx: SkillContext, name: str, shape: Shape, z: float, thickness: float = 0.008) -> Shape:
    """The object's collision geometry within ``thickness`` of height ``z``, as a box in its own axes:
    a flask's neck, not its body."""
    w = ctx.world
    m, d = w.model, w.data
    body = w.body_id(name)
    rot, origin = d.xmat[body].reshape(3, 3), d.xpos[body]
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for g in np.flatnonzero(m.geom_bodyid == body):
        if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
            continue
        grot = d.geom_xmat[g].reshape(3, 3)
        center = d.geom_xpos[g] + grot @ m.geom_aabb[g, :3]
        zhalf = float(np.abs(grot[2]) @ m.geom_aabb[g, 3:])
        if abs(center[2] - z) > zhalf + thickness:
            continue
        local = rot.T @ grot
        c = rot.T @ (center - origin)
        h = np.abs(local) @ m.geom_aabb[g, 3:]
        lo, hi = np.minimum(lo, c - h), np.maximum(hi, c + h)
    if not np.all(np.isfinite(lo)):
        return shape
    return Shape(origin + rot @ ((lo + hi) / 2), rot.copy(), (hi - lo) / 2)


def _narrow_side(shape: Shape, radial: np.ndarray, vertical: int) -> tuple[np.ndarray, float]:
    """Close across the object's narrower horizontal side (radially when it is round)."""
    a, b = (i for i in range(3) if i != vertical)
    widths = {a: 2 * float(shape.half[a]), b: 2 * float(shape.half[b])}
    if abs(widths[a] - widths[b]) < 0.002:
        return radial, widths[a]
    narrow = a if widths[a] < widths[b] else b
    return horizontal(shape.axes[:, narrow]), widths[narrow]


def grip_geom(
    ctx: SkillContext, name: str, point: np.ndarray, site: str | None
) -> tuple[np.ndarray, np.ndarray] | None:
    """Centre and half-size of the smallest collision geom of the site's body (of the object, without a
    site) that reaches within a centimetre of ``point``: a grip or a neck, not the lid it sticks out of."""
    w = ctx.world
    m, d = w.model, w.data
    bodies = {int(m.site_bodyid[w.site_id(site)])} if site is not None else ctx.scene.bodies(name)
    best = None
    for body in bodies:
        for g in np.flatnonzero(m.geom_bodyid == body):
            if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
                continue
            center = d.geom_xpos[g] + d.geom_xmat[g].reshape(3, 3) @ m.geom_aabb[g, :3]
            half = np.abs(d.geom_xmat[g].reshape(3, 3)) @ m.geom_aabb[g, 3:]
            if np.all(np.abs(center - point) <= half + 0.01):
                volume = float(np.prod(half))
                if best is None or volume < best[0]:
                    best = (volume, center, half)
    return None if best is None else (best[1], best[2])


def at_site(grip: tuple[np.ndarray, np.ndarray] | None, site: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``grip`` (a :func:`_grip_geom` found at a named site), or ``None`` where its centre lies more than
    :data:`SITE_SLACK` from the site: the plate a flush site sits on the edge of, not a handle."""
    return grip if grip is not None and np.linalg.norm(grip[0] - site) <= SITE_SLACK else None


def _local_closing(
    ctx: SkillContext, name: str, point: np.ndarray, shape: Shape, site: str | None = None
) -> tuple[np.ndarray, float, bool]:
    """At a named site (a handle bar, a neck): close across the grip there (:func:`_grip_geom`);
    and whether the grip is round (a neck, closed along the radial; a bar is not, even when its
    across-direction happens to point at the robot)."""
    grip = grip_geom(ctx, name, point, site)
    radial = horizontal(point - ctx.base)
    if grip is None:
        return radial, 0.0, True
    size = 2 * grip[1]
    if abs(size[0] - size[1]) < 0.004:
        return radial, float(min(size[0], size[1])), True
    # a bar: close across it
    if size[0] > size[1]:
        return np.array([0.0, 1.0, 0.0]), float(size[1]), False
    return np.array([1.0, 0.0, 0.0]), float(size[0]), False


def side_candidates(ctx: SkillContext, name: str, at: str) -> list[Grasp]:
    """A handle on a vertical face (a door's bar, a drawer's grip), taken from in front of the face,
    the hand level, closing across the handle."""
    point = ctx.world.position(at)
    grip = grip_geom(ctx, name, point, at)
    normal = ctx.scene.face_normal(point, name, prefer=ctx.base - point)
    normal[2] = 0.0
    if np.linalg.norm(normal) < 0.5:
        normal = -horizontal(point - ctx.base)
    normal = normal / np.linalg.norm(normal)
    across = np.cross(UP, -normal)
    if grip is not None and grip[1][2] < abs(grip[1] @ across):
        closing = UP.copy()  # a grip wider than tall (a lid's front lip): the fingers close above and below it
    else:
        closing = across  # a bar standing up (a door's handle): the fingers close round it sideways
    handle = at_site(grip, point)
    center = point if handle is None else handle[0]  # centred on the grip's cross-section
    out = []
    for tilt in (0.0, 20.0, -20.0):
        approach = np.cos(np.deg2rad(tilt)) * -normal - np.sin(np.deg2rad(tilt)) * UP
        rot = tool_frame(approach, closing)
        out.append(Grasp("side", center.copy(), rot, [center - 0.10 * approach, center - 0.04 * approach], 0.0))
    return out


def top_candidates(
    ctx: SkillContext,
    point: np.ndarray,
    closing: np.ndarray,
    shape: Shape,
    width: float,
    lying: bool,
    round_: bool = False,
    bar: tuple[np.ndarray, np.ndarray] | None = None,
) -> list[Grasp]:
    """Straight down, then pitched: toward the robot where the fingers then close across the grip (a
    round object from any side), else tilted along the grip (a lying tool along its length, a bar
    facing the robot along the bar), so the fingers still close across it. A ``bar`` (centre and
    half-size of a handle's grip geom) lying across the robot's view is last taken from in front."""
    out = []
    above = max(0.10, shape.top - point[2] + 0.06)
    radial = horizontal(point - ctx.base)
    length = np.array([closing[1], -closing[0], 0.0])
    along = [length if length @ radial >= 0 else -length]
    if abs(length @ radial) < 0.5:  # lying across the radial direction: either end may be the one
        along.append(-along[0])
    late = []  # lying along it: tilted toward the near end last (what comes next may need that tilt)
    for pitch in TOP_PITCHES:
        if pitch >= 89.9:
            rots = [down_frame(closing)]
        elif round_ or (not lying and abs(radial @ horizontal(closing)) <= 0.5):
            rots = [pitched_frame(radial, pitch)]  # toward the robot: the fingers close across the radial
        else:  # tilted along the grip (a lying tool, a bar facing the robot): the fingers still close across it
            rots = [pitched_frame(toward, pitch) for toward in along]
            if lying and len(along) == 1:
                late.append(pitched_frame(-along[0], pitch))
        for rot in rots:
            out.append(_from_above(point, rot, above, width))
    out += [_from_above(point, rot, above, width) for rot in late]
    if bar is not None and abs(length @ radial) < 0.5:
        out += _front_of_bar(ctx, bar, radial)
    return out


def _from_above(point: np.ndarray, rot: np.ndarray, above: float, width: float) -> Grasp:
    """A grasp at ``point`` approached back along the hand's axis, at least half ``above`` over it."""
    back = point - rot[:, 2] * above
    back[2] = max(back[2], point[2] + above * 0.5)
    return Grasp("top", point.copy(), rot, [back], width)


def _front_of_bar(ctx: SkillContext, bar: tuple[np.ndarray, np.ndarray], radial: np.ndarray) -> list[Grasp]:
    """A bar across the robot's view (a lid's handle) taken from in front, the hand level (the short
    arm's way: no reaching over it): the lower finger slides in just under the bar, where there is
    room above the surface below, and closing lifts the bar onto it."""
    center, half = bar
    bottom = center - half[2] * UP
    gap, _ = ctx.scene.ray(bottom - 0.001 * UP, -UP)
    if gap < BAR_GAP:
        return []
    tcp = center.copy()
    tcp[2] = max(center[2], bottom[2] - 0.003 + ctx.robot.gripper.max_opening / 2)
    out = []
    for closing in (UP, -UP):  # the two rolls of a symmetric gripper: one may suit the wrist better
        approach = [tcp - 0.10 * radial, tcp - 0.04 * radial]
        out.append(Grasp("front", tcp.copy(), tool_frame(radial, closing), approach, 2 * float(half[2])))
    return out


def pinch_candidates(
    ctx: SkillContext, name: str, shape: Shape, toward: np.ndarray | None, above: bool = False
) -> list[Grasp]:
    out = []
    radial = horizontal(shape.center - ctx.base)
    # facing the robot first; from the side where the near rim is too close to the base to come from
    directions = [radial, *(axis_rotation(UP, np.deg2rad(a)) @ radial for a in PINCH_TURNS)]
    if toward is not None:
        directions.insert(0, horizontal(toward))
    for radial in directions:
        out += _pinches(ctx, name, shape, radial, above)
    return out


def _corner_drop(ctx: SkillContext, rot: np.ndarray) -> float:
    """How far below the tcp the open fingertips' lowest corner reaches with the hand turned ``rot``."""
    gripper = ctx.robot.gripper
    approach, across = rot[:, 2], rot[:, 0]
    return float(-(gripper.fingertip * approach[2]) + abs(across[2]) * gripper.finger_thickness / 2)


def _reach_in(ctx: SkillContext, rot: np.ndarray) -> float:
    """How far beyond the tcp, horizontally along the approach's heading, the fingers reach with the
    hand turned ``rot``: their tips and corners as the model has them (the Panda's 14 mm at 30 deg
    below the horizon; none for the Piper, whose tcp is at its fingertips)."""
    return max(0.0, float(np.max((ctx.hand.finger_corners @ rot.T) @ horizontal(rot[:, 2]))))


def _pinches(ctx: SkillContext, name: str, shape: Shape, radial: np.ndarray, above: bool = False) -> list[Grasp]:
    """Pinches facing ``radial``: over the rim from behind it, or (``above``) from straight above it."""
    opening = ctx.robot.gripper.max_opening
    center = shape.center
    round_ = 2 * abs(shape.half[0] - shape.half[1]) < ROUND if shape.vertical_axis() == 2 else False
    chord = opening - 2 * GRIP_MARGIN / 3
    if round_:
        r = float(max(shape.half[0], shape.half[1]))  # its own box: a turned dish is as wide as ever
        c = min(2 * r, chord)
        depth = float(np.sqrt(max(0.0, r * r - (c / 2) ** 2)))
    else:
        # a rectangle: along the radial direction, the far side is depth away; the fingers must span the
        # side across it
        across = float(2 * np.abs(np.array([-radial[1], radial[0], 0.0]) @ shape.axes) @ shape.half)
        if across > chord:
            raise SkillFailure(
                f"no grasp for {name!r}: it is {across * 1000:.0f} mm across the fingers at its rim; "
                f"the {ctx.robot.name}'s gripper opens {opening * 1000:.0f} mm"
            )
        c, depth = across, 0.0
    height = shape.top - shape.bottom
    out = []
    for rise in (height * 0.5 + 0.015,) if above else (height * 0.5 + 0.015, 0.004):
        for pitch in PINCH_PITCHES:
            rot = pitched_frame(radial, pitch)
            at, width = depth, c
            if round_ and depth > 0.0:
                # the chord where the fingers close, so the open fingers clear the wider chords their
                # tips and corners reach further in (the disc wedged between them, fully open); but no
                # nearer the rim than where its wall meets the fingers inside their friction cone (there
                # the squeeze pushes the disc out: a 150 mm dish taken that way, 0/5)
                held = r * float(np.sin(np.arctan(FINGER_FRICTION)))
                at = max(depth, min(depth + _reach_in(ctx, rot), held))
                width = 2.0 * float(np.sqrt(max(0.0, r * r - at * at)))
            pinch = np.array([center[0], center[1], shape.bottom]) - at * radial + 0.63 * height * UP
            # no lower than keeps the fingertips' lower corners over what it stands on: planned into the
            # bench, the arm pressed them on it at 80-100 N and friction held the fingers open
            pinch[2] = max(pinch[2], shape.bottom + _corner_drop(ctx, rot) + CORNER_ROOM)
            # over the rim and down onto the chord; or (under a shelf) level, where the open fingers slide
            # in until the rim itself stops them at the chord
            over = pinch + rise * UP
            start = over + PINCH_DROP * UP if above else over - 0.12 * radial
            out.append(Grasp("pinch", pinch, rot, [start, over], width))
    return out
