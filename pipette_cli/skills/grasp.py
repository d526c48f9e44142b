"""Grasps from an object's shape and semantics: where the fingers go and how the hand is turned.

Three kinds, chosen from the object's collision box in the world and its asset's ``pipette:*``
semantics (ManiSkill-style: from the oriented bounding box, with the arm's reach deciding between
candidates):

* ``axis``: an upright object narrow enough for the gripper (a tube, a flask's neck, a bottle) is
  taken from above around its vertical axis, at its ``grasp`` site (or a named site), low enough
  that its top stays below the palm and high enough that the fingertips close above the rack,
  rotor or holder it stands in (the open fingers would otherwise close on its walls).
* ``across``: a lying tool (a pipette, a rod, a syringe, tweezers) is taken from above across its
  long axis, low ones too.
* ``pinch``: a flat, low object (a petri dish, a plate) is pinched near the rim facing the robot
  with the hand pitched down, across the widest chord the gripper spans; the pitch lets the
  fingertips reach below its rim without touching the surface under it.

When the straight-down hand cannot reach (a short arm, far away), the approach is pitched toward
the robot in steps until it can. The candidates are built in :mod:`.grasp_candidates`; this module
chooses the first the arm reaches, and follows through with, touching nothing else.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pipette_cli.skills.frames import UP
from pipette_cli.skills.grasp_candidates import (
    Grasp,
    at_site,
    grasp_point,
    grip_geom,
    pinch_candidates,
    side_candidates,
    top_candidates,
)
from pipette_cli.skills.grip import FLAT, LONG, fits_gripper, flat
from pipette_cli.skills.moves import COMFORT, SkillFailure
from pipette_cli.skills.runtime import SkillContext

LIFT_CHECK = 0.015
"""Metres above the grasp the arm must also reach, to take the object off its support."""


FollowThrough = Callable[["Grasp"], list[tuple[np.ndarray, np.ndarray]]]


def pinched(height: float, footprint: np.ndarray, mode: str = "auto", at: str | None = None) -> bool:
    """Whether an object ``height`` tall with ``footprint`` (its two horizontal sizes) is pinched at
    its rim, the hand pitched (a flat dish or plate), rather than taken from above."""
    short, long_ = sorted(float(v) for v in footprint)
    return mode == "pinch" or (mode == "auto" and at is None and flat(height, footprint) and long_ <= LONG * short)


def plan_grasp(
    ctx: SkillContext,
    name: str,
    *,
    at: str | None = None,
    mode: str = "auto",
    height: float | None = None,
    above: float | None = None,
    toward: np.ndarray | None = None,
    then: FollowThrough | None = None,
    later: FollowThrough | None = None,
    exact: bool = False,
) -> Grasp:
    """The first reachable grasp of ``name`` (see the module docstring). ``toward`` is the horizontal
    direction the hand should point for what comes next (into an enclosure): pinches and pitched
    grasps try it first. ``then`` gives the tool poses the hand must reach after the grasp, in straight
    lines (pulling a handle along its arc): a grasp the arm cannot follow through with is not taken.
    ``later`` gives poses the hand goes to afterwards through free space (where what it holds is
    taken next): a grasp that leaves one of them out of reach is not taken either. With ``exact`` (the
    poses are the ones the next step goes to, not one of its choices), grasps leaving them in
    comfortable reach come first: a long tool held at one end droops in the fingers, and the pose
    moves with it. ``above``: an upright object is taken at least that high over its origin."""
    shape = ctx.scene.shape(name)
    opening = ctx.robot.gripper.max_opening
    half = shape.world_half()
    size = 2 * half
    low = size[2] < FLAT
    footprint = np.sort(np.delete(shape.half, shape.vertical_axis()))  # its own box: yaw does not matter
    long_ = bool(footprint[1] > LONG * footprint[0])
    if pinched(2 * half[2], 2 * footprint, mode, at):
        try:
            return _first_reachable(ctx, name, pinch_candidates(ctx, name, shape, toward), "pinch", then, later, exact)
        except SkillFailure:  # a near rim too close to the base to come at from the side: from straight above
            overhead = pinch_candidates(ctx, name, shape, toward, above=True)
            return _first_reachable(ctx, name, overhead, "pinch", then, later, exact)
    if mode == "side":
        if at is None:
            raise SkillFailure(f"a side grasp of {name!r} needs a site to grasp at ('at:')")
        return _first_reachable(ctx, name, side_candidates(ctx, name, at), "side", then, later, exact)
    axis_obj = shape.axes[:, shape.vertical_axis()]
    lying = abs(axis_obj[2]) < 0.7 or (
        at is None and shape.half[shape.vertical_axis()] < np.max(shape.half) * 0.6 and (long_ or not low)
    )
    point, closing, width, round_ = grasp_point(ctx, name, shape, at, height, lying, above)
    if not fits_gripper(width, opening):
        raise SkillFailure(
            f"no grasp for {name!r}: it is {width * 1000:.0f} mm across where it would be held; the "
            f"{ctx.robot.name}'s gripper opens {opening * 1000:.0f} mm"
        )
    bar = at_site(grip_geom(ctx, name, point, at), point) if at is not None and not round_ else None
    return _first_reachable(
        ctx,
        name,
        top_candidates(ctx, point, closing, shape, width, lying, round_ and not lying, bar),
        "across" if lying else "axis",
        then,
        later,
        exact,
    )


def _first_reachable(
    ctx: SkillContext,
    name: str,
    candidates: list[Grasp],
    kind: str,
    then: FollowThrough | None = None,
    later: FollowThrough | None = None,
    exact: bool = False,
) -> Grasp:
    touch = ctx.scene.bodies(name) | support_of(ctx, name)
    if later is not None:
        margins = [ctx.plan.margin(later(g), touch, collisions=False) for g in candidates]
        order = sorted((exact and m < COMFORT, i) for i, m in enumerate(margins) if m is not None)
        candidates = [candidates[i] for _, i in order]

    def poses(g: Grasp) -> list[tuple[np.ndarray, np.ndarray]]:
        after = then(g) if then is not None else [(g.pos + LIFT_CHECK * UP, g.rot)]
        return [(p, g.rot) for p in (*g.approach, g.pos)] + after

    chosen = ctx.plan.choose(
        candidates, poses, touch=touch, via=lambda g: (g.approach[0], g.rot, ctx.scene.bodies(name))
    )
    if chosen is not None:
        return chosen
    distance = float(np.linalg.norm(ctx.world.position(name)[:2] - ctx.base[:2]))
    raise SkillFailure(
        f"no reachable {kind} grasp of {name!r} ({distance:.2f} m from the {ctx.robot.name}'s base, "
        f"reach {ctx.robot.reach:.2f} m)"
    )


def support_of(ctx: SkillContext, name: str) -> set[int]:
    """The body ``name`` rests on, as a set (empty when nothing is under it): fingertips reaching low
    may graze it, so a grasp may touch it."""
    shape = ctx.scene.shape(name)
    _, body = ctx.scene.ray(
        np.array([shape.center[0], shape.center[1], shape.bottom + 0.002]), -UP, ctx.scene.bodies(name)
    )
    return {body} if body >= 0 else set()
