"""Where things go: the world points a step's target names, and where a held object meets what it
is set on or put into (its base, its mating point, its lowest point, held upright).

Geometry only, no moves: the skills (:mod:`.library`) and the shared motions of
:mod:`.handling` plan with these.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pipette_cli.skills.frames import UP, axis_rotation, down_frame, horizontal, rotation_angle
from pipette_cli.skills.moves import Held
from pipette_cli.skills.runtime import SkillContext
from pipette_cli.specs.expert import InsertIntoSpec, TargetSpec

FINGER_ROOM = 0.002
"""Metres the closed fingertips keep above what surrounds a hole an object is put into."""
PAD_REACH = 0.008
"""Metres a closed finger reaches beyond the object it holds, along the closing direction."""
SEATED = 0.004
"""Metres above its seat within which an object counts as in its hole (it is let go 3 mm up)."""
STANDING_TILT = 12.0
"""Degrees from upright within which an object let go in its hole counts as standing there."""
SLIP_ROOM = 0.003
"""Metres more than the least that an object to be put into a hole is taken higher up (it may slip
up in the fingers on the way)."""


SEAT = "_seat"
"""Sites named ``*_seat`` (a water bath's ``lid_seat``) are where what goes there rests, its base on
the site: no surface is looked for under them (under a lid's seat is the open tank)."""


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
            point = top_of(ctx, spec.at)
        point = point + np.asarray(spec.offset)
    if surface and not (spec.at and spec.at.endswith(SEAT)):  # a seat is where the base goes itself
        skip = ctx.hand.held_bodies()
        point = point.copy()
        point[2] = ctx.scene.surface_below(point[0], point[1], skip, from_z=point[2] + 0.03)
    return point


def top_of(ctx: SkillContext, name: str) -> np.ndarray:
    """The middle of an object's top: its ``*center`` site if its asset names one, else its box."""
    centers = [s for s in ctx.scene.semantics(name).get("sites", []) if str(s).endswith("center")]
    if centers:
        return ctx.world.position(f"{name}/{centers[0]}")
    shape = ctx.scene.shape(name)
    return np.array([shape.center[0], shape.center[1], shape.top])


def base_offset(ctx: SkillContext, name: str) -> float:
    """How far the object's origin is above its lowest point (0 for assets authored on their base)."""
    return float(ctx.world.position(name)[2] - ctx.scene.shape(name).bottom)


def mating_point(ctx: SkillContext, name: str) -> np.ndarray:
    """Where ``name`` meets a holder, in its own frame: where it hangs from (``hang_height`` above its
    origin, a pipette's collar) or its base (a tube)."""
    hang = ctx.scene.semantics(name).get("hang_height")
    return np.array([0.0, 0.0, float(hang) if hang else 0.0])


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
    below = mate[2] - lowest_along_axis(ctx, step.object)  # how far the object reaches below its mating point
    rise = max(0.0, rim - site[2]) + below + 0.02

    def final(tool_rot: np.ndarray, held: Held) -> np.ndarray:
        return site + 0.003 * UP - (tool_rot @ held.rot) @ mate - tool_rot @ held.pos

    return final, rise


def lowest_along_axis(ctx: SkillContext, name: str) -> float:
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


def finger_floor(ctx: SkillContext, name: str, tcp: np.ndarray, rot: np.ndarray) -> float:
    """The lowest height the tcp (as it stands) may take at ``tcp``'s place, turned ``rot``, with
    the fingers closed on ``name``: lower, the fingertips would land on what surrounds the hole (a
    rack's top grid, a rotor) before the object is seated. Where the fingers fit into the hole with
    the object, that is the hole's floor."""
    gripper = ctx.robot.gripper
    approach, closing = rot[:, 2], rot[:, 1]
    across = np.cross(approach, closing)
    shape = ctx.scene.shape(name)
    half = float(np.abs(closing @ shape.axes) @ shape.half)
    tip = gripper.fingertip * approach
    skip = ctx.hand.held_bodies() | ctx.scene.bodies(name)
    from_z = float(tcp[2] + tip[2] + 0.05)
    top = -np.inf
    for side in (-1.0, 1.0):
        for reach in (half + 0.001, half + PAD_REACH):
            for off in (-0.5, 0.0, 0.5):
                p = tcp + side * reach * closing + off * gripper.finger_thickness * across
                top = max(top, ctx.scene.surface_below(p[0], p[1], skip, from_z=from_z))
    return float(top + FINGER_ROOM - tip[2])


def opening_floor(ctx: SkillContext, name: str, tcp: np.ndarray, rot: np.ndarray) -> float:
    """The lowest height the tcp may take at ``tcp``, turned ``rot``, for the fingers to open off
    ``name`` without landing on what surrounds it: their tips sweep out from the object to the full
    opening and their outer edges beyond it (a microtube rack's end wall stands 3 mm over its grid,
    and a hand tilted 5 degrees dips an opening fingertip 4 mm more)."""
    gripper = ctx.robot.gripper
    approach, closing = rot[:, 2], rot[:, 1]
    across = np.cross(approach, closing)
    shape = ctx.scene.shape(name)
    held = float(np.abs(closing @ shape.axes) @ shape.half)
    corners = np.abs(ctx.hand.finger_corners[:, 1])
    outer = gripper.max_opening / 2 + max(PAD_REACH, float(corners.max() - corners.min()))
    skip = ctx.hand.held_bodies() | ctx.scene.bodies(name)
    floor = -np.inf
    for side in (-1.0, 1.0):
        for reach in np.linspace(held + 0.001, outer, 8):
            for off in (-0.5, 0.0, 0.5):
                tip = side * reach * closing + off * gripper.finger_thickness * across + gripper.fingertip * approach
                p = tcp + tip
                surface = ctx.scene.surface_below(p[0], p[1], skip, from_z=float(p[2] + 0.05))
                floor = max(floor, surface + FINGER_ROOM - float(tip[2]))
    return float(floor)


def seat_gap(ctx: SkillContext, name: str, site: np.ndarray) -> float:
    """Metres the object's mating point (its base, or where it hangs from) stands above ``site``."""
    mate = ctx.world.position(name) + ctx.world.rotation(name) @ mating_point(ctx, name)
    return float(mate[2] - site[2])


def standing_in(ctx: SkillContext, name: str, site: np.ndarray) -> bool:
    """Whether ``name`` stands upright in the hole at ``site`` (to be taken again and pushed home)."""
    mate = ctx.world.position(name) + ctx.world.rotation(name) @ mating_point(ctx, name)
    half = float(np.min(ctx.scene.shape(name).world_half()[:2]))
    tilt = np.rad2deg(np.arccos(np.clip(ctx.world.rotation(name)[2, 2], -1.0, 1.0)))
    return bool(tilt < STANDING_TILT and np.linalg.norm(mate[:2] - site[:2]) < half)


def insertion_grasp(ctx: SkillContext, step: InsertIntoSpec) -> float:
    """How high over its origin ``step.object`` must be taken for ``step`` to seat it in its hole
    with the closed fingers over what surrounds the hole (a rack's top grid), and
    :data:`SLIP_ROOM` more: a tube taken low would be let go above its seat."""
    site = ctx.world.position(step.target)
    rot = down_frame(horizontal(site - ctx.plan.base))
    length = 2 * float(ctx.scene.shape(step.object).world_half().max())
    floor = finger_floor(ctx, step.object, site + length * UP, rot)
    seated_origin = site[2] + 0.003 - mating_point(ctx, step.object)[2]
    return floor - seated_origin + SLIP_ROOM
