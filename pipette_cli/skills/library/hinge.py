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

from collections.abc import Iterator
from dataclasses import dataclass

import mujoco
import numpy as np

from pipette_cli.skills.frames import UP, axis_rotation, down_frame, horizontal, pitched_frame, tool_frame
from pipette_cli.skills.runtime import (
    APPROACH_SPEED, CLOSED, FINE_SPEED, OPEN, Move, SkillContext, SkillFailure, skill,
)
from pipette_cli.specs.expert import CloseHingeSpec, HingeSpec, OpenHingeSpec, SlideSpec

TOLERANCE_DEG = 3.0
PUSH_REACHES = (0.85, 0.7, 0.55, 0.4)
"""Where along the lid the fingers push: fractions of the handle's distance from the hinge, tried
in turn (far out needs the least force, nearer the hinge is easier to reach)."""
STANDOFF = 0.025
"""Metres between the tcp and the face it pushes (the fingers' half thickness and a little)."""
MAX_PASSES = 3
SETTLED_RAD_S = 0.05


@dataclass(frozen=True)
class Hinge:
    """A revolute joint in the world: anchor, unit axis, current angle and range (degrees)."""

    joint: str
    anchor: np.ndarray
    axis: np.ndarray
    angle: float
    low: float
    high: float

    def point(self, p0: np.ndarray, angle0: float, angle: float) -> np.ndarray:
        """Where a point ``p0`` of the moving part (taken at ``angle0``) is at ``angle``."""
        return self.anchor + axis_rotation(self.axis, np.deg2rad(angle - angle0)) @ (p0 - self.anchor)

    def motion(self, p: np.ndarray, sign: float) -> np.ndarray:
        """Unit direction a point ``p`` of the part moves in when the angle changes with ``sign``."""
        v = np.cross(self.axis, p - self.anchor) * sign
        return v / (np.linalg.norm(v) + 1e-12)


def read_hinge(ctx: SkillContext, joint: str) -> Hinge:
    w = ctx.world
    jid = w.joint_id(joint)
    if w.model.jnt_type[jid] != mujoco.mjtJoint.mjJNT_HINGE:
        raise SkillFailure(f"{joint!r} is not a hinge; use the slide skill for sliding parts")
    low, high = np.rad2deg(w.model.jnt_range[jid])
    return Hinge(joint, w.data.xanchor[jid].copy(), w.data.xaxis[jid].copy(), w.joint(joint), float(low), float(high))


def _moving_bodies(ctx: SkillContext, joint: str) -> set[int]:
    """The bodies a joint moves (the lid or door and what hangs from it)."""
    m = ctx.world.model
    child = int(m.jnt_bodyid[ctx.world.joint_id(joint)])
    out = {child}
    for b in range(m.nbody):
        parent = b
        while parent > 0 and parent not in out:
            parent = int(m.body_parentid[parent])
        if parent in out:
            out.add(b)
    return out


def settle(ctx: SkillContext, joint: str, limit_s: float = 1.5) -> Iterator[Move]:
    """Hold still until ``joint`` comes to rest (a lid still swinging from being released or set)."""
    w = ctx.world
    dof = w.model.jnt_dofadr[w.joint_id(joint)]
    waited = 0.0
    while abs(float(w.data.qvel[dof])) > SETTLED_RAD_S and waited < limit_s:
        yield ctx.hold(0.1)
        waited += 0.1


def goal_angle(ctx: SkillContext, hinge: Hinge, step: HingeSpec, opening: bool) -> float:
    """The target angle: the step's, else the asset's open/closed angle, else 0 (closed) or the far
    end of the range (open). Assets close at 0 and open toward the other end of their range."""
    if step.to_deg is not None:
        return step.to_deg
    from pipette_cli.skills.grasp import semantics

    sem = semantics(ctx, hinge.joint.split("/", 1)[0])
    key = "lid_open_angle_deg" if opening else "lid_closed_angle_deg"
    if key in sem:
        return float(sem[key])
    if not opening:
        return 0.0 if hinge.low <= 0.0 <= hinge.high else (hinge.low if abs(hinge.low) < abs(hinge.high) else hinge.high)
    far = hinge.high if abs(hinge.high) >= abs(hinge.low) else hinge.low
    return 0.9 * far


def handle_point(ctx: SkillContext, hinge: Hinge, step: HingeSpec) -> np.ndarray:
    """The named handle, else a ``*handle`` site of the part's asset, else the part's farthest point."""
    if step.handle is not None:
        return ctx.world.position(step.handle)
    obj = hinge.joint.split("/", 1)[0]
    from pipette_cli.skills.grasp import semantics

    handles = [s for s in semantics(ctx, obj).get("sites", []) if "handle" in str(s)]
    body = ctx.world.model.jnt_bodyid[ctx.world.joint_id(hinge.joint)]
    for name in handles:
        sid = ctx.world.site_id(f"{obj}/{name}")
        if ctx.world.model.site_bodyid[sid] == body:
            return ctx.world.position(f"{obj}/{name}")
    raise SkillFailure(f"{hinge.joint!r}: the part has no handle site; name one with 'handle:'")


@skill("close_hinge")
def close_hinge(ctx: SkillContext, step: CloseHingeSpec) -> Iterator[Move]:
    if ctx.held is not None:
        raise SkillFailure(f"the hand holds {ctx.held.name!r}; put it down before closing {step.joint!r}")
    if ctx.gripper != CLOSED:
        yield ctx.grip(CLOSED, 0.3)
    yield from settle(ctx, step.joint)
    hinge = read_hinge(ctx, step.joint)
    goal = goal_angle(ctx, hinge, step, opening=False)
    if abs(hinge.angle - goal) <= TOLERANCE_DEG:
        return
    handle = handle_point(ctx, hinge, step)
    sign = float(np.sign(goal - hinge.angle))
    angle0 = hinge.angle
    moving = _moving_bodies(ctx, step.joint)
    overshoot = goal + sign * 2.0

    def push_point(reach: float, angle: float, off: float) -> np.ndarray:
        p = hinge.point(hinge.anchor + reach * (handle - hinge.anchor), angle0, angle)
        return p - off * hinge.motion(p, sign)

    def sweep(reach: float, start: float) -> list[np.ndarray]:
        behind = min(max(start - sign * 4.0, hinge.low), hinge.high)  # a little behind the part as it stands
        return [push_point(reach, float(a), STANDOFF) for a in np.linspace(behind, overshoot, 8)]

    def frame(reach: float, pitch: float) -> np.ndarray:
        p = push_point(reach, angle0, 0.0)
        if pitch >= 89.9:
            closing = np.cross(hinge.motion(p, sign), UP)
            return down_frame(closing if np.linalg.norm(closing[:2]) > 0.1 else hinge.axis)
        return pitched_frame(p - ctx.base, pitch)

    candidates = [(reach, pitch) for reach in PUSH_REACHES for pitch in (90.0, 60.0, 45.0)]

    def poses(candidate: tuple[float, float]) -> list[tuple[np.ndarray, np.ndarray]]:
        reach, pitch = candidate
        rot = frame(reach, pitch)
        points = sweep(reach, angle0)
        return [(points[0] - 0.05 * hinge.motion(points[0], sign) + 0.02 * UP, rot), *((p, rot) for p in points[::2]),
                (points[-1], rot)]

    def approach_of(candidate: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        first = sweep(candidate[0], angle0)[0]
        return first - 0.05 * hinge.motion(first, sign) + 0.02 * UP, frame(*candidate)

    chosen = ctx.choose(candidates, poses, via=approach_of, touch=moving)
    if chosen is None:
        raise SkillFailure(f"no reachable way to push {step.joint!r} shut")
    reach, pitch = chosen
    rot = frame(reach, pitch)
    start = angle0
    for attempt in range(MAX_PASSES):
        points = sweep(reach, start)
        approach, _ = approach_of((reach, pitch)) if attempt == 0 else (points[0] - 0.05 * hinge.motion(points[0], sign) + 0.02 * UP, rot)
        yield from ctx.transit(approach, rot, what=f"the approach to {step.joint!r}")
        with ctx.touching(moving):
            yield ctx.move(points[0], rot, speed=APPROACH_SPEED, what=f"the push on {step.joint!r}")
            for point in points[1:]:
                yield ctx.move(point, rot, speed=FINE_SPEED * 3, what=f"pushing {step.joint!r}")
        now = ctx.world.joint(step.joint)
        if abs(now - goal) <= TOLERANCE_DEG or np.sign(goal - now) != sign:
            break
        if attempt > 0 and abs(now - start) < 1.0:
            raise SkillFailure(f"{step.joint!r} does not move (stays at {now:.0f} deg, goal {goal:.0f} deg)")
        start = now
    end = ctx.pos
    with ctx.touching(moving):
        yield ctx.move(end + 0.02 * UP - 0.02 * hinge.motion(end, sign), rot, speed=APPROACH_SPEED, what="backing off")
        yield from ctx.lift_clear(0.10)
    if step.hold_s:
        yield ctx.hold(step.hold_s)


@skill("open_hinge")
def open_hinge(ctx: SkillContext, step: OpenHingeSpec) -> Iterator[Move]:
    from pipette_cli.skills.library.pick import grasp

    if ctx.held is not None:
        raise SkillFailure(f"the hand holds {ctx.held.name!r}; put it down before opening {step.joint!r}")
    hinge = read_hinge(ctx, step.joint)
    goal = goal_angle(ctx, hinge, step, opening=True)
    if abs(hinge.angle - goal) <= TOLERANCE_DEG:
        return
    handle = handle_point(ctx, hinge, step)
    obj = step.joint.split("/", 1)[0]
    handle_site = step.handle or _handle_site(ctx, hinge, handle)
    yield from grasp(ctx, obj, at=handle_site, mode=_handle_mode(ctx, hinge, handle))
    ctx.held = None  # the part is articulated, not carried: the hand follows its arc
    moving = _moving_bodies(ctx, step.joint)
    ctx.allowed = ctx.allowed | moving
    sign = float(np.sign(goal - hinge.angle))
    tcp0, rot0, angle0 = ctx.pos.copy(), ctx.rot.copy(), hinge.angle
    steps = max(3, int(abs(goal - angle0) / 8.0))
    angle = angle0
    for target in np.linspace(angle0, goal + sign * 2.0, steps + 1)[1:]:
        turn = axis_rotation(hinge.axis, np.deg2rad(target - angle0))
        pos = hinge.anchor + turn @ (tcp0 - hinge.anchor)
        yield ctx.move(pos, turn @ rot0, speed=FINE_SPEED * 3, what=f"opening {step.joint!r}")
        now = ctx.world.joint(step.joint)
        if abs(now - target) > 15.0:
            raise SkillFailure(f"{step.joint!r} does not follow the hand (at {now:.0f} deg, hand at {target:.0f} deg): "
                               "the handle slipped")
        angle = now
    yield ctx.grip(OPEN, 0.4)
    from pipette_cli.skills.library.place import back_off

    yield from back_off(ctx, 0.08)
    ctx.allowed = ctx.allowed - moving
    if abs(ctx.world.joint(step.joint) - goal) > 10.0 and abs(angle - goal) > 10.0:
        raise SkillFailure(f"{step.joint!r} stopped at {angle:.0f} deg, short of {goal:.0f} deg")
    if step.hold_s:
        yield ctx.hold(step.hold_s)


def _handle_site(ctx: SkillContext, hinge: Hinge, handle: np.ndarray) -> str:
    obj = hinge.joint.split("/", 1)[0]
    from pipette_cli.skills.grasp import semantics

    for name in semantics(ctx, obj).get("sites", []):
        if np.linalg.norm(ctx.world.position(f"{obj}/{name}") - handle) < 1e-6:
            return f"{obj}/{name}"
    raise SkillFailure(f"{hinge.joint!r}: no handle site to grasp")


def _handle_mode(ctx: SkillContext, hinge: Hinge, handle: np.ndarray) -> str:
    """A handle on a vertical face (a door's bar) is taken from the side, one on top from above."""
    return "side" if abs(hinge.axis[2]) > 0.7 else "top"


@skill("slide")
def slide(ctx: SkillContext, step: SlideSpec) -> Iterator[Move]:
    w = ctx.world
    jid = w.joint_id(step.joint)
    if w.model.jnt_type[jid] != mujoco.mjtJoint.mjJNT_SLIDE:
        raise SkillFailure(f"{step.joint!r} is not a sliding joint; use open_hinge/close_hinge")
    low, high = w.model.jnt_range[jid]
    goal = high if step.to == "open" else low if step.to == "closed" else float(step.to)
    now = w.joint(step.joint)
    if abs(now - goal) < 0.005:
        return
    axis = w.data.xaxis[jid].copy()
    obj = step.joint.split("/", 1)[0]
    body = w.model.jnt_bodyid[jid]
    part = ctx.scene.bodies(obj)
    face = _front_face(ctx, body, axis * np.sign(goal - now))
    if ctx.held is not None:
        raise SkillFailure(f"the hand holds {ctx.held.name!r}; put it down before moving {step.joint!r}")
    pushing = True
    direction = axis * np.sign(goal - now)
    rot = tool_frame(horizontal(direction) if abs(direction[2]) < 0.7 else -UP, np.array([0.0, 0.0, 1.0]) if abs(direction[2]) < 0.7 else np.array([1.0, 0.0, 0.0]))
    if not pushing:  # pragma: no cover - every built-in slide is driven by pushing its front
        pass
    if ctx.gripper != CLOSED:
        yield ctx.grip(CLOSED, 0.3)
    start = face - 0.05 * direction
    yield from ctx.transit(start, rot, exclude=part, what=f"the approach to {step.joint!r}")
    travel = abs(goal - now)
    yield ctx.move(face + (travel + 0.005) * direction, rot, speed=FINE_SPEED * 2, what=f"sliding {step.joint!r}")
    yield ctx.move(ctx.pos - 0.05 * direction, rot, speed=APPROACH_SPEED, what="backing off")
    if abs(w.joint(step.joint) - goal) > 0.01:
        raise SkillFailure(f"{step.joint!r} is at {w.joint(step.joint):.3f} m, not {goal:.3f} m")
    if step.hold_s:
        yield ctx.hold(step.hold_s)


def _front_face(ctx: SkillContext, body: int, direction: np.ndarray) -> np.ndarray:
    """The centre of the sliding part's face that trails ``direction`` (the face to push)."""
    w = ctx.world
    m, d = w.model, w.data
    best, point = np.inf, None
    for g in np.flatnonzero(m.geom_bodyid == body):
        if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
            continue
        center = d.geom_xpos[g] + d.geom_xmat[g].reshape(3, 3) @ m.geom_aabb[g, :3]
        half = np.abs(d.geom_xmat[g].reshape(3, 3)) @ m.geom_aabb[g, 3:]
        back = center - half * np.abs(direction) * np.sign(direction.sum() or 1.0)
        depth = float(back @ direction)
        if depth < best:
            best, point = depth, center - np.abs(direction) * half * np.sign(direction @ np.ones(3))
    if point is None:
        raise SkillFailure("the sliding part has no collision geometry to push")
    return point
