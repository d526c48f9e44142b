"""Where things go: the world points a step's target names, and where a held object meets what it
is set on or put into (its base, its mating point, its lowest point, held upright).

Geometry only, no moves: the skills (:mod:`.library`) and the shared motions of
:mod:`.handling` plan with these.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pipette_cli.skills.frames import UP, axis_rotation, rotation_angle
from pipette_cli.skills.moves import Held
from pipette_cli.skills.runtime import SkillContext
from pipette_cli.specs.expert import InsertIntoSpec, TargetSpec


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
    if surface:
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
