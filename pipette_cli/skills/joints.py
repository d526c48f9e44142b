"""An instrument's moving parts as the skills read them: a hinge's anchor, axis, angle and range,
the bodies a joint moves, the part's plate and handle, the angle a step asks for, and waiting for
a swinging part to come to rest. The hinge and slide skills (:mod:`.library.hinge`) work with these.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import mujoco
import numpy as np
from mink.utils import get_subtree_body_ids

from pipette_cli.skills.frames import axis_rotation
from pipette_cli.skills.moves import Move, SkillFailure
from pipette_cli.skills.runtime import SkillContext
from pipette_cli.specs.expert import HingeSpec

SETTLED_RAD_S = 0.05
"""Radians per second under which a joint counts as at rest."""


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


def moving_bodies(ctx: SkillContext, joint: str) -> set[int]:
    """The bodies a joint moves (the lid or door and what hangs from it)."""
    m = ctx.world.model
    child = int(m.jnt_bodyid[ctx.world.joint_id(joint)])
    return set(get_subtree_body_ids(m, child))


def wait_until_still(ctx: SkillContext, joint: str, limit_s: float = 1.5) -> Iterator[Move]:
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

    sem = ctx.scene.semantics(hinge.joint.split("/", 1)[0])
    key = "lid_open_angle_deg" if opening else "lid_closed_angle_deg"
    if key in sem:
        return float(sem[key])
    if not opening:
        return (
            0.0 if hinge.low <= 0.0 <= hinge.high else (hinge.low if abs(hinge.low) < abs(hinge.high) else hinge.high)
        )
    far = hinge.high if abs(hinge.high) >= abs(hinge.low) else hinge.low
    return 0.9 * far


def plate_edge(ctx: SkillContext, joint: str) -> tuple[np.ndarray, float]:
    """The far edge of the part's plate (its largest collision geom), at mid-thickness, and the
    plate's half-thickness: where pushing it needs the least force."""
    w = ctx.world
    m, d = w.model, w.data
    hinge = read_hinge(ctx, joint)
    best = None
    for g in np.flatnonzero(np.isin(m.geom_bodyid, list(moving_bodies(ctx, joint)))):  # the first of equals
        if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
            continue
        volume = float(np.prod(m.geom_aabb[g, 3:]))
        if best is None or volume > best[0]:
            best = (volume, g)
    if best is None:
        raise SkillFailure(f"{joint!r}: the moving part has no collision geometry to push")
    g = best[1]
    rot = d.geom_xmat[g].reshape(3, 3)
    center = d.geom_xpos[g] + rot @ m.geom_aabb[g, :3]
    half = m.geom_aabb[g, 3:]
    out = center - hinge.anchor
    out -= hinge.axis * float(hinge.axis @ out)
    out /= np.linalg.norm(out) + 1e-12
    reach = float(np.abs(rot.T @ out) @ half)
    thickness = float(np.abs(rot.T @ np.cross(hinge.axis, out)) @ half)
    return center + reach * out, thickness


def part_handle(ctx: SkillContext, joint: str) -> str | None:
    """A ``*handle`` site on the body ``joint`` moves."""
    obj = joint.split("/", 1)[0]
    body = ctx.world.model.jnt_bodyid[ctx.world.joint_id(joint)]
    for name in ctx.scene.semantics(obj).get("sites", []):
        if "handle" in str(name) and ctx.world.model.site_bodyid[ctx.world.site_id(f"{obj}/{name}")] == body:
            return f"{obj}/{name}"
    return None
