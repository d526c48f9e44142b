"""``open_hinge``, ``close_hinge`` and ``slide``: move an instrument's lid, door or drawer.

All three read the joint from the model (anchor, axis, range) and the part's handle from the
asset's sites; they run as loops (paper-style hinges are stiff, friction holds part-open lids):
move a little along the arc, read the joint, stop at the target or on a stall and try again.

* ``close_hinge`` pushes the lid or door with the closed fingers, on the face away from the
  motion, sweeping along its arc past the closed angle; a second pass catches a lid that fell
  ahead of the hand and stopped on its friction.
* ``open_hinge`` grasps the handle and carries it along the arc, the hand turning with the part.
* ``slide`` grasps the handle (or the front) and pulls or pushes it along the joint's axis.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator

import mujoco
import numpy as np

from pipette_cli.skills.frames import UP, axis_rotation, down_frame, pitched_frame
from pipette_cli.skills.grasp import plan_grasp
from pipette_cli.skills.handling import grasp
from pipette_cli.skills.joints import (
    goal_angle,
    moving_bodies,
    part_handle,
    plate_edge,
    read_hinge,
    wait_until_still,
)
from pipette_cli.skills.motions import back_off, lift_clear, transit
from pipette_cli.skills.moves import APPROACH_SPEED, CLOSED, FINE_SPEED, OPEN, Move, SkillFailure
from pipette_cli.skills.runtime import SkillContext, skill
from pipette_cli.specs.expert import CloseHingeSpec, OpenHingeSpec, SlideSpec

log = logging.getLogger(__name__)

TOLERANCE_DEG = 3.0
PUSH_REACHES = (0.85, 0.7, 0.55, 0.4)
"""Where along the lid the fingers push: fractions of the handle's distance from the hinge, tried
in turn (far out needs the least force, nearer the hinge is easier to reach)."""
STANDOFF = 0.025
"""Metres between the tcp and the face it pushes (the fingers' half thickness and a little)."""
MAX_PASSES = 3
MIN_PULL_DEG = 24.0
"""Degrees a handle's grasp must let the arm follow the arc (enough to reach behind the part and push)."""
FOLLOW = (1.0, 0.5, 0.0)
PULL_STEP = 8.0
"""Degrees per move while pulling a handle along its arc (the joint is read after each)."""
TIP_PITCHES = (0.0, 30.0)
"""Degrees below the horizon a hand pushing with its fingertips points, in the order tried."""
APPROACHES = {"behind": (0.05, 0.02), "above": (0.01, 0.06)}
"""How the hand comes to the push's first point: metres back from the face and up. From behind, level
with it; from above, down along the face (a lid leaning back, past upright: the wrist behind a pitched
hand would cross the lid on the way in from behind)."""


Push = tuple[float, float, bool, str]
"""A way to push a part: where along it (fraction), the hand's pitch, fingertips first, the approach."""


def push_arc(ctx: SkillContext, joint: str, goal: float, moving: set[int]) -> Iterator[Move]:
    """Sweep the closed fingers along the part's arc toward ``goal``, pushing the face that moves away
    from them; passes again where the part stopped short (friction, a lid that fell ahead of the hand)."""
    hinge = read_hinge(ctx, joint)
    edge, thickness = plate_edge(ctx, joint)
    sign = float(np.sign(goal - hinge.angle))
    angle0 = hinge.angle
    overshoot = goal + sign * 2.0
    fingers = ctx.robot.gripper
    gap = STANDOFF - 0.5 * fingers.finger_thickness  # metres between the fingers and the face at the standoff
    room = (hinge.high - overshoot) if sign > 0 else (overshoot - hinge.low)
    length = float(np.linalg.norm(edge - hinge.anchor))

    def push_point(reach: float, angle: float, standoff: float) -> np.ndarray:
        p = hinge.point(hinge.anchor + reach * (edge - hinge.anchor), angle0, angle)
        return p - standoff * hinge.motion(p, sign)

    def lead_in(first: np.ndarray, way: str) -> np.ndarray:
        back, up = APPROACHES[way]
        return first - back * hinge.motion(first, sign) + up * UP

    def sweep(candidate: Push, start: float) -> list[np.ndarray]:
        reach, _, tips, _ = candidate
        behind = min(max(start - sign * 4.0, hinge.low), hinge.high)  # a little behind the part as it stands
        # the fingers trail the tcp by the gap: sweep on by that much where the range leaves room (a lid
        # lifted against its weight stays where the fingers leave it)
        end = overshoot + sign * max(0.0, min(np.rad2deg(gap / (reach * length)), room))
        off = thickness + gap + (fingers.fingertip if tips else 0.5 * fingers.finger_thickness)
        return [push_point(reach, float(a), off) for a in np.linspace(behind, end, 8)]

    def frame(candidate: Push) -> np.ndarray:
        reach, pitch, tips, _ = candidate
        p = push_point(reach, angle0, 0.0)
        if tips:  # the fingertips first along the push: the wrist stays back from the part's face
            return pitched_frame(hinge.motion(p, sign), pitch)
        if pitch >= 89.9:
            closing = np.cross(hinge.motion(p, sign), UP)
            return down_frame(closing if np.linalg.norm(closing[:2]) > 0.1 else hinge.axis)
        return pitched_frame(p - ctx.base, pitch)

    def approach_of(candidate: Push) -> tuple[np.ndarray, np.ndarray]:
        return lead_in(sweep(candidate, angle0)[0], candidate[3]), frame(candidate)

    def poses(candidate: Push) -> list[tuple[np.ndarray, np.ndarray]]:
        rot = frame(candidate)
        points = sweep(candidate, angle0)
        return [approach_of(candidate), *((p, rot) for p in points[::2]), (points[-1], rot)]

    # the side of the closed fingers, the hand pitched down; where none reaches (the wrist would touch a
    # door's face, a lid far out), the fingertips first along the push; each coming in from behind the
    # face, then (none of those clear) from above it
    candidates = [
        (reach, pitch, False, way) for way in APPROACHES for reach in PUSH_REACHES for pitch in (90.0, 60.0, 45.0)
    ]
    tips = [(reach, pitch, True, way) for way in APPROACHES for reach in PUSH_REACHES for pitch in TIP_PITCHES]
    chosen = ctx.plan.choose(candidates, poses, via=approach_of, touch=moving)
    if chosen is None:
        chosen = ctx.plan.choose(tips, poses, via=approach_of, touch=moving)
        candidates += tips
    if chosen is None:
        if not any(ctx.plan.reachable(*poses(c)[1]) for c in candidates):
            edge_now = push_point(PUSH_REACHES[0], angle0, 0.0)
            raise SkillFailure(
                f"reach: the push on {joint!r} starts {edge_now[2] - ctx.base[2]:.2f} m above the "
                f"{ctx.robot.name}'s base and {np.linalg.norm((edge_now - ctx.base)[:2]):.2f} m out; no hand "
                "pose reaches it"
            )
        raise SkillFailure(f"no reachable way to push {joint!r} to {goal:.0f} deg without touching anything else")
    rot = frame(chosen)
    start = angle0
    for attempt in range(MAX_PASSES):
        points = sweep(chosen, start)
        yield from transit(ctx, lead_in(points[0], chosen[3]), rot, what=f"the approach to {joint!r}")
        with ctx.hand.touching(moving):
            yield ctx.move(points[0], rot, speed=APPROACH_SPEED, what=f"the push on {joint!r}")
            for point in points[1:]:
                yield ctx.move(point, rot, speed=FINE_SPEED * 3, what=f"pushing {joint!r}")
        now = ctx.world.joint(joint)
        if abs(now - goal) <= TOLERANCE_DEG or np.sign(goal - now) != sign:
            break
        if attempt > 0 and abs(now - start) < 1.0:
            raise SkillFailure(f"{joint!r} does not move (stays at {now:.0f} deg, goal {goal:.0f} deg)")
        start = now
    end = ctx.hand.pos
    with ctx.hand.touching(moving):
        yield ctx.move(end + 0.02 * UP - 0.02 * hinge.motion(end, sign), rot, speed=APPROACH_SPEED, what="backing off")
        yield from lift_clear(ctx, 0.10)


@skill(CloseHingeSpec)
def close_hinge(ctx: SkillContext, step: CloseHingeSpec) -> Iterator[Move]:
    if ctx.hand.held is not None:
        raise SkillFailure(f"the hand holds {ctx.hand.held.name!r}; put it down before closing {step.joint!r}")
    if ctx.hand.gripper != CLOSED:
        yield ctx.grip(CLOSED, 0.3)
    yield from wait_until_still(ctx, step.joint)
    hinge = read_hinge(ctx, step.joint)
    goal = goal_angle(ctx, hinge, step, opening=False)
    if abs(hinge.angle - goal) > TOLERANCE_DEG:
        yield from push_arc(ctx, step.joint, goal, moving_bodies(ctx, step.joint))
    if step.hold_s:
        yield ctx.hold(step.hold_s)


@skill(OpenHingeSpec)
def open_hinge(ctx: SkillContext, step: OpenHingeSpec) -> Iterator[Move]:
    """Pull the handle along the arc as far as the arm follows it, then push the part the rest of the way."""
    if ctx.hand.held is not None:
        raise SkillFailure(f"the hand holds {ctx.hand.held.name!r}; put it down before opening {step.joint!r}")
    yield from wait_until_still(ctx, step.joint)
    hinge = read_hinge(ctx, step.joint)
    goal = goal_angle(ctx, hinge, step, opening=True)
    if abs(hinge.angle - goal) <= TOLERANCE_DEG:
        return
    obj = step.joint.split("/", 1)[0]
    moving = moving_bodies(ctx, step.joint)
    handle_site = step.handle or part_handle(ctx, step.joint)
    sign = float(np.sign(goal - hinge.angle))
    if handle_site is not None:
        # a handle on a front face (a door's bar, a lid's front lip) is taken from in front; one on top from above
        normal = ctx.scene.face_normal(ctx.world.position(handle_site), obj, prefer=ctx.base - hinge.anchor)
        angle0 = hinge.angle
        targets = [
            float(np.clip(t, min(angle0, goal + sign * 2.0), max(angle0, goal + sign * 2.0)))
            for t in np.arange(angle0 + sign * PULL_STEP, goal + sign * (PULL_STEP + 2.0), sign * PULL_STEP)
        ]

        def pull_pose(pos: np.ndarray, rot: np.ndarray, target: float, follow: float) -> tuple[np.ndarray, np.ndarray]:
            """The handle's place at ``target``, the hand turned ``follow`` of the way with it (the
            handle turns in the fingers for the rest)."""
            turn = axis_rotation(hinge.axis, np.deg2rad(target - angle0))
            return hinge.anchor + turn @ (pos - hinge.anchor), axis_rotation(
                hinge.axis, np.deg2rad(follow * (target - angle0))
            ) @ rot

        # a grasp the arm can follow round the first part of the arc (what stays is pushed); the hand
        # turns with the handle if it can, half as much, or not at all
        mode = "top" if normal[2] > 0.9 else "side"
        follow = None
        for follow in FOLLOW:
            arc = lambda g, f=follow: [
                pull_pose(g.pos, g.rot, t, f) for t in targets if abs(t - angle0) <= MIN_PULL_DEG + 1e-6
            ]
            try:
                plan_grasp(ctx, obj, at=handle_site, mode=mode, then=arc)
                break
            except SkillFailure:
                continue
        else:
            raise SkillFailure(
                f"no grasp of {handle_site!r} the {ctx.robot.name} can pull {MIN_PULL_DEG:.0f} deg along "
                f"the arc of {step.joint!r}"
            )
        yield from grasp(ctx, obj, at=handle_site, mode=mode, extra_touch=moving, then=arc)
        ctx.hand.held = None  # the part is articulated, not carried: the hand follows its arc
        tcp0, rot0 = ctx.hand.pos.copy(), ctx.hand.rot.copy()
        with ctx.hand.touching(moving):
            for target in targets:
                # the hand turns with the handle as far as the arm lets it (less from here on where not)
                move = None
                for f in (x for x in FOLLOW if x <= follow):
                    pos, rot = pull_pose(tcp0, rot0, target, f)
                    try:
                        move = ctx.move(pos, rot, speed=FINE_SPEED * 3, what=f"opening {step.joint!r}")
                    except SkillFailure as exc:
                        log.debug("pulling %s stops at %.0f deg: %s", step.joint, ctx.world.joint(step.joint), exc)
                        continue
                    follow = f
                    break
                if move is None:
                    break  # the arm cannot follow further: let go and push the rest
                yield move
                if abs(ctx.world.joint(step.joint) - target) > 15.0:
                    break  # the grip slipped: push the rest
                if sign * (ctx.world.joint(step.joint) - goal) >= 0:
                    break
            yield ctx.grip(OPEN, 0.4)
            yield from back_off(ctx, 0.06)
        yield from wait_until_still(ctx, step.joint)
    if abs(ctx.world.joint(step.joint) - goal) > TOLERANCE_DEG and sign * (ctx.world.joint(step.joint) - goal) < 0:
        if ctx.hand.gripper != CLOSED:
            yield ctx.grip(CLOSED, 0.3)
        yield from push_arc(ctx, step.joint, goal, moving)
    if step.hold_s:
        yield ctx.hold(step.hold_s)


@skill(SlideSpec)
def slide(ctx: SkillContext, step: SlideSpec) -> Iterator[Move]:

    w = ctx.world
    jid = w.joint_id(step.joint)
    if w.model.jnt_type[jid] != mujoco.mjtJoint.mjJNT_SLIDE:
        raise SkillFailure(f"{step.joint!r} is not a sliding joint; use open_hinge/close_hinge")
    if ctx.hand.held is not None:
        raise SkillFailure(f"the hand holds {ctx.hand.held.name!r}; put it down before moving {step.joint!r}")
    low, high = (float(v) for v in w.model.jnt_range[jid])
    goal = high if step.to == "open" else low if step.to == "closed" else float(step.to)
    now = w.joint(step.joint)
    if abs(now - goal) < 0.005:
        return
    axis = w.data.xaxis[jid].copy()
    direction = axis * np.sign(goal - now)
    obj = step.joint.split("/", 1)[0]
    moving = moving_bodies(ctx, step.joint)
    handle = step.handle or part_handle(ctx, step.joint)
    if handle is None:
        raise SkillFailure(
            f"{step.joint!r}: the sliding part has no handle site to move it by; name one with 'handle:'"
        )
    yield from grasp(ctx, obj, at=handle, mode="side" if abs(direction[2]) < 0.7 else "top")
    ctx.hand.held = None  # the part slides on its joint; the hand follows
    with ctx.hand.touching(moving):
        travel = abs(goal - now)
        yield ctx.move(ctx.hand.pos + travel * direction, speed=FINE_SPEED * 2, what=f"sliding {step.joint!r}")
        yield ctx.grip(OPEN, 0.4)
        yield from back_off(ctx, 0.06)
    reached = w.joint(step.joint)
    if abs(reached - goal) > 0.02:
        raise SkillFailure(f"{step.joint!r} is at {reached:.3f} m, not {goal:.3f} m: the grip slipped")
    if step.hold_s:
        yield ctx.hold(step.hold_s)
