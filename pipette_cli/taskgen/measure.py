"""Geometry the drafting code needs, measured from the compiled assets and robots.

Everything is in the asset's own frame (origin at the bottom centre of its footprint), for
the authored pose of static assets and the resting pose of free ones. Results are cached per
process: measuring every asset of the library takes about a second.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from functools import cache
from typing import Any

import mujoco
import numpy as np

from pipette_cli.assets.library import load_asset_library
from pipette_cli.assets.loader import load_asset_spec
from pipette_cli.sim.quaternions import quat_to_mat
from pipette_cli.sim.scene import collision_boxes, set_physics
from pipette_cli.specs.task import TimingSpec

FREE_CATEGORIES = ("tools", "consumables")


def r(value: float, nd: int = 3) -> float:
    """``value`` rounded to ``nd`` places as a plain float (no -0.0), the way drafted YAML writes numbers."""
    return round(float(value), nd) + 0.0


@dataclass(frozen=True)
class JointInfo:
    """A hinge (degrees) or slide (metres) with its limits."""

    name: str
    kind: str  # "hinge" | "slide"
    low: float
    high: float

    @property
    def open_limit(self) -> float:
        """The limit farther from 0 (closed): the fully open value."""
        return self.high if abs(self.high) >= abs(self.low) else self.low

    @property
    def unit(self) -> str:
        return "deg" if self.kind == "hinge" else "m"


@dataclass(frozen=True)
class AssetGeometry:
    """Collision boxes, sites and joints of one asset."""

    asset_id: str
    category: str
    free: bool
    semantics: dict[str, Any]
    boxes: np.ndarray  # (n, 6): min xyz, max xyz of every collision geom
    sites: dict[str, tuple[float, float, float]]
    joints: dict[str, JointInfo]
    rest_euler_deg: tuple[float, float, float]

    @property
    def low(self) -> np.ndarray:
        return self.boxes[:, :3].min(axis=0)

    @property
    def high(self) -> np.ndarray:
        return self.boxes[:, 3:].max(axis=0)

    @property
    def half_xy(self) -> tuple[float, float]:
        """Half the footprint, about the origin (the larger side of each axis)."""
        lo, hi = self.low, self.high
        return float(max(-lo[0], hi[0])), float(max(-lo[1], hi[1]))

    @property
    def radius_xy(self) -> float:
        """Radius of the smallest disc about the origin that holds the footprint."""
        hx, hy = self.half_xy
        return float(np.hypot(hx, hy))

    @property
    def origin_height(self) -> float:
        """Height of the origin above the surface the object rests on (0 for most assets)."""
        return float(-self.low[2])

    @property
    def height(self) -> float:
        return float(self.high[2] - self.low[2])


def _point(xyz: np.ndarray) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in xyz)
    return x, y, z


def quat_to_euler_deg(quat: Iterable[float]) -> tuple[float, float, float]:
    """wxyz quaternion -> intrinsic x-y-z Euler angles in degrees (MuJoCo's eulerseq "xyz")."""
    r = quat_to_mat(np.asarray(quat, dtype=float))
    b = np.arcsin(np.clip(r[0, 2], -1.0, 1.0))
    a = np.arctan2(-r[1, 2], r[2, 2])
    c = np.arctan2(-r[0, 1], r[0, 0])
    x, y, z = (round(float(np.rad2deg(v)), 6) + 0.0 for v in (a, b, c))  # + 0.0: no -0.0
    return x, y, z


@cache
def measure_asset(
    asset_id: str, joint_values: tuple[tuple[str, float], ...] = (), *, standing: bool = False
) -> AssetGeometry:
    """Compile ``asset_id`` alone (rest pose, joints at ``joint_values``: deg / m) and measure it.

    With ``standing``, a free object is measured in its authored frame (its own z axis up, as it
    stands in a rack's hole) instead of the pose it rests in on a bench (a conical tube lies on its
    side); ``semantics["upright"]`` then says it stands.
    """
    entry = load_asset_library().get(asset_id)
    semantics = entry.semantics()
    free = entry.category in FREE_CATEGORIES
    spec = load_asset_spec(asset_id, free_joint=free)
    model = spec.compile()
    data = mujoco.MjData(model)
    rest = semantics.get("rest_quat") or [1.0, 0.0, 0.0, 0.0]
    if standing and free:
        rest = [1.0, 0.0, 0.0, 0.0]
        semantics = {**semantics, "upright": True}
    if free and model.njnt and int(model.jnt_type[0]) == int(mujoco.mjtJoint.mjJNT_FREE):
        data.qpos[3:7] = rest
    joints: dict[str, JointInfo] = {}
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])
        if kind not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            continue
        hinge = kind == int(mujoco.mjtJoint.mjJNT_HINGE)
        low, high = model.jnt_range[j]
        scale = np.rad2deg(1.0) if hinge else 1.0
        joints[model.joint(j).name] = JointInfo(
            model.joint(j).name,
            "hinge" if hinge else "slide",
            round(float(low * scale), 4),
            round(float(high * scale), 4),
        )
    for name, value in joint_values:
        info = joints[name]
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = np.deg2rad(value) if info.kind == "hinge" else value
    mujoco.mj_forward(model, data)
    boxes = collision_boxes(model, data, range(model.ngeom))
    sites = {model.site(i).name: _point(data.site_xpos[i]) for i in range(model.nsite)}
    return AssetGeometry(
        asset_id,
        entry.category,
        free,
        semantics,
        boxes,
        sites,
        joints,
        quat_to_euler_deg(rest) if free else (0.0, 0.0, 0.0),
    )


HOLD_SECONDS = 3.0
"""Seconds a part is left alone at an angle to see whether its hinge friction holds it there."""
HOLD_SHARE = 0.75
"""Share of the angle it must keep (a friction-held lid creeps back a few degrees)."""


@cache
def holds_open(asset_id: str, joint: str, angle: float) -> bool:
    """Whether the part on ``joint`` (a hinge) of ``asset_id`` left alone at ``angle`` degrees stays
    open (keeps :data:`HOLD_SHARE` of it) on its friction, with the asset's own drives off."""
    model = load_asset_spec(asset_id, free_joint=False).compile()
    model.actuator_gainprm[:] = 0.0
    model.actuator_biasprm[:] = 0.0
    data = mujoco.MjData(model)
    adr = model.jnt_qposadr[model.joint(joint).id]
    data.qpos[adr] = np.deg2rad(angle)
    for _ in range(int(HOLD_SECONDS / model.opt.timestep)):
        mujoco.mj_step(model, data)
    return abs(float(np.rad2deg(data.qpos[adr]))) >= HOLD_SHARE * abs(angle)


STAND_SECONDS = 1.5
"""Seconds an object is left alone on a flat floor to see whether it stays as put."""
STAND_NUDGES = ((3.0, 0.0, 0.0), (0.0, 3.0, 0.0), (0.0, 0.0, 0.05))
"""Tips about x and y (degrees) and a sideways push (m/s) it is released with, one at a time: a
resting pose is only one if a nudge does not topple or roll it (a cone balanced on its point, a
cylinder on its side stay put only unnudged)."""
STAND_TILT_DEG = 10.0
STAND_DRIFT = 0.02


@cache
def stands_alone(asset_id: str) -> bool:
    """Whether a free object stays where it is put on a flat surface in its rest pose: a conical
    tube tips over and a tube lying on its side rolls away (they belong in a rack); a flask or a
    dish stays. Simulated once per asset and nudge (:data:`STAND_NUDGES`), alone on a plane."""

    entry = load_asset_library().get(asset_id)
    if entry.category not in FREE_CATEGORIES:
        return True
    spec = load_asset_spec(asset_id, free_joint=True)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1.0, 1.0, 0.1])
    set_physics(spec, TimingSpec().physics_dt)
    model = spec.compile()
    data = mujoco.MjData(model)
    geom = measure_asset(asset_id)
    rest = np.asarray(geom.semantics.get("rest_quat") or [1.0, 0.0, 0.0, 0.0], dtype=float)
    for tilt_x, tilt_y, push in STAND_NUDGES:
        mujoco.mj_resetData(model, data)
        tip = np.zeros(4)
        mujoco.mju_euler2Quat(tip, np.deg2rad([tilt_x, tilt_y, 0.0]), "xyz")
        quat = np.zeros(4)
        mujoco.mju_mulQuat(quat, tip, rest)
        data.qpos[:7] = [0.0, 0.0, geom.origin_height + 0.001, *quat]
        data.qvel[:2] = push / np.sqrt(2.0)
        mujoco.mj_forward(model, data)
        start, up = data.xpos[1].copy(), data.xmat[1].reshape(3, 3)[:, 2].copy()
        for _ in range(int(STAND_SECONDS / model.opt.timestep)):
            mujoco.mj_step(model, data)
        tilt = np.rad2deg(np.arccos(np.clip(float(data.xmat[1].reshape(3, 3)[:, 2] @ up), -1.0, 1.0)))
        if tilt > STAND_TILT_DEG or float(np.linalg.norm(data.xpos[1][:2] - start[:2])) > STAND_DRIFT:
            return False
    return True
