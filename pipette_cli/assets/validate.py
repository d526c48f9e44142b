"""Check assets: usd-core's ``UsdValidation`` framework, our semantics, MuJoCo compile, physics.

Physics checks run each asset alone in a small scene:

* free objects (tools, consumables, lift-off lids) are dropped from 2 mm onto a plane in their
  resting orientation and must come to rest: no NaN, no jitter (speed over the last 0.25 s),
  no penetration deeper than 1.5 mm, no tipping over when authored upright;
* static assets (equipment, instruments) are welded to the world; every hinge or slide joint is
  pushed to its upper then its lower limit (by its actuator when it has one, otherwise by a
  generalised force larger than gravity and friction) and must reach both.

Validation never writes to the asset files.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
from pxr import UsdGeom, UsdValidation

from pipette_cli.assets.loader import attach_asset, load_asset_spec
from pipette_cli.assets.semantics import open_stage
from pipette_cli.errors import AssetError

SETTLE_SECONDS = 1.5
WINDOW_SECONDS = 0.25
MAX_REST_SPEED = 0.02  # m/s, over the last window
MAX_REST_SPIN = 0.6  # rad/s
MAX_PENETRATION = 0.0015  # m
MAX_TILT_DEG = 10.0
SWEEP_SECONDS = 2.0
REQUIRED_SEMANTICS = ("category", "description", "graspable", "static", "mass", "dimensions", "main_body", "sites")
USD_VALIDATORS = (
    "usdValidation:CompositionErrorTest",
    "usdValidation:StageMetadataChecker",
    "usdGeomValidators:StageMetadataChecker",
    "usdGeomValidators:EncapsulationChecker",
    "usdShadeValidators:MaterialBindingApiAppliedValidator",
    "usdShadeValidators:MaterialBindingRelationships",
    "usdPhysicsValidators:RigidBodyChecker",
    "usdPhysicsValidators:ColliderChecker",
    "usdPhysicsValidators:PhysicsJointChecker",
    "usdPhysicsValidators:ArticulationChecker",
    "usdUtilsValidators:MissingReferenceValidator",
)


@dataclass
class AssetReport:
    """Outcome of validating one asset; ``problems`` is empty when it passed."""

    asset_id: str
    path: Path
    problems: list[str] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.problems

    def as_dict(self) -> dict:
        return {
            "id": self.asset_id,
            "path": str(self.path),
            "ok": self.ok,
            "problems": self.problems,
            "metrics": {k: round(v, 6) for k, v in self.metrics.items()},
            "seconds": round(self.seconds, 3),
        }


def usd_problems(stage) -> list[str]:
    """Errors reported by usd-core's own validators (core, geom, shade, physics, utils)."""
    registry = UsdValidation.ValidationRegistry()
    validators = [registry.GetOrLoadValidatorByName(name) for name in USD_VALIDATORS]
    context = UsdValidation.ValidationContext([v for v in validators if v])
    out = []
    for error in context.Validate(stage):
        if error.GetType() in (UsdValidation.ValidationErrorType.Error, UsdValidation.ValidationErrorType.Warn):
            sites = ", ".join(str(s.GetPrim().GetPath()) for s in error.GetSites() if s.IsPrim()) or "stage"
            out.append(
                f"UsdValidation {error.GetValidator().GetMetadata().name if error.GetValidator() else ''}: {sites}: {error.GetMessage()}"
            )
    return out


def semantic_problems(stage, category: str | None) -> list[str]:
    """Missing or inconsistent ``pipette:*`` semantics on the default prim."""
    root = stage.GetDefaultPrim()
    out = []
    for key in REQUIRED_SEMANTICS:
        if not root.HasAttribute(f"pipette:{key}"):
            out.append(f"semantics: missing attribute pipette:{key}")
    cat = root.GetAttribute("pipette:category").Get() if root.HasAttribute("pipette:category") else None
    if category and cat and cat != category:
        out.append(f"semantics: pipette:category is {cat!r} but the file is in folder {category!r}")
    names = {p.GetName() for p in stage.Traverse()}
    for s in root.GetAttribute("pipette:sites").Get() or [] if root.HasAttribute("pipette:sites") else []:
        if s not in names:
            out.append(f"semantics: site {s!r} is listed but no prim has that name")
    if UsdGeom.GetStageUpAxis(stage) != UsdGeom.Tokens.z or UsdGeom.GetStageMetersPerUnit(stage) != 1.0:
        out.append("stage: must be Z-up with metersPerUnit = 1")
    return out


def _attr(stage, name: str, default=None):
    root = stage.GetDefaultPrim()
    attr = root.GetAttribute(f"pipette:{name}")
    return attr.Get() if attr and attr.HasAuthoredValue() else default


def _free_scene(path: Path, rest_quat):
    scene = mujoco.MjSpec()
    scene.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.1])
    attach_asset(scene, path, name="asset", quat=tuple(rest_quat))
    model = scene.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    low = min(
        float(data.geom_xpos[g][2] - (np.abs(data.geom_xmat[g].reshape(3, 3)) @ model.geom_aabb[g, 3:])[2])
        for g in range(model.ngeom)
        if model.geom_contype[g] and model.geom_bodyid[g] > 0
    )
    data.qpos[2] += 0.002 - low
    mujoco.mj_forward(model, data)
    return model, data


def settle_free(path: Path, rest_quat, upright: bool) -> tuple[list[str], dict[str, float]]:
    """Drop a free object onto a plane; return problems and metrics."""
    model, data = _free_scene(path, rest_quat)
    start_pos = data.qpos[:3].copy()
    start_axis = data.xmat[1].reshape(3, 3)[:, 2].copy()
    steps = int(SETTLE_SECONDS / model.opt.timestep)
    window = int(WINDOW_SECONDS / model.opt.timestep)
    speed = spin = 0.0
    depth = 0.0
    for i in range(steps):
        mujoco.mj_step(model, data)
        if not np.all(np.isfinite(data.qpos)):
            return ["physics: simulation diverged (NaN) while settling"], {}
        if i >= steps - window:
            speed = max(speed, float(np.linalg.norm(data.qvel[:3])))
            spin = max(spin, float(np.linalg.norm(data.qvel[3:6])))
            if data.ncon:
                depth = max(depth, float(-data.contact.dist[: data.ncon].min()))
    axis = data.xmat[1].reshape(3, 3)[:, 2]
    tilt = math.degrees(math.acos(float(np.clip(axis @ start_axis, -1, 1))))
    drift = float(np.linalg.norm(data.qpos[:2] - start_pos[:2]))
    metrics = {"rest_speed": speed, "rest_spin": spin, "penetration": depth, "tilt_deg": tilt, "drift": drift}
    problems = []
    if speed > MAX_REST_SPEED or spin > MAX_REST_SPIN:
        problems.append(
            f"physics: not at rest after {SETTLE_SECONDS} s (speed {speed:.3f} m/s, spin {spin:.2f} rad/s): jitter or rolling"
        )
    if depth > MAX_PENETRATION:
        problems.append(f"physics: sinks {depth * 1000:.1f} mm into the table (limit {MAX_PENETRATION * 1000:.1f} mm)")
    if upright and tilt > MAX_TILT_DEG:
        problems.append(f"physics: authored upright but tips over by {tilt:.0f} deg")
    if drift > 0.05:
        problems.append(f"physics: slides {drift * 100:.1f} cm while settling")
    return problems, metrics


def sweep_joints(path: Path) -> tuple[list[str], dict[str, float]]:
    """Weld a static asset to the world and drive each joint to both limits."""
    scene = mujoco.MjSpec()
    scene.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3, 3, 0.1])
    attach_asset(scene, path, name="asset")
    model = scene.compile()
    data = mujoco.MjData(model)
    problems: list[str] = []
    metrics: dict[str, float] = {}
    steps = int(SWEEP_SECONDS / model.opt.timestep)
    for _ in range(int(0.3 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    if not np.all(np.isfinite(data.qpos)):
        return ["physics: simulation diverged (NaN) at rest"], metrics
    actuated = {
        int(model.actuator_trnid[a, 0]): a
        for a in range(model.nu)
        if int(model.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
    }
    for j in range(model.njnt):
        if int(model.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            continue
        name = model.joint(j).name.split("/", 1)[-1]
        lo, hi = model.jnt_range[j]
        if not model.jnt_limited[j] or hi <= lo:
            problems.append(f"joint {name}: needs limits")
            continue
        qadr, dof = model.jnt_qposadr[j], model.jnt_dofadr[j]
        push = _push_force(model, data, j)
        for target, label in ((hi, "upper"), (lo, "lower")):
            mujoco.mj_resetData(model, data)
            start = lo if target == hi else hi
            data.qpos[qadr] = start
            if j in actuated:
                data.ctrl[actuated[j]] = np.clip(target, *model.actuator_ctrlrange[actuated[j]])
            else:
                data.qfrc_applied[dof] = push if target == hi else -push
            for _ in range(steps):
                mujoco.mj_step(model, data)
            q = float(data.qpos[qadr])
            if not np.isfinite(q):
                problems.append(f"joint {name}: diverged (NaN) while moving to its {label} limit")
                break
            metrics[f"{name}_{label}"] = q
            tol = 0.06 * (hi - lo)
            if abs(q - target) > tol:
                problems.append(f"joint {name}: stops at {q:.3f}, short of its {label} limit {target:.3f}")
            if q < lo - tol or q > hi + tol:
                problems.append(f"joint {name}: leaves its range [{lo:.3f}, {hi:.3f}] ({q:.3f})")
    return problems, metrics


def _push_force(model, data, joint: int) -> float:
    """A generalised force beating gravity and friction anywhere in the joint's range."""
    lo, hi = model.jnt_range[joint]
    qadr, dof = model.jnt_qposadr[joint], model.jnt_dofadr[joint]
    worst = inertia = 0.0
    for q in np.linspace(lo, hi, 7):
        mujoco.mj_resetData(model, data)
        data.qpos[qadr] = q
        mujoco.mj_forward(model, data)
        worst = max(worst, abs(float(data.qfrc_bias[dof])))
        unit, column = np.zeros(model.nv), np.zeros(model.nv)
        unit[dof] = 1.0
        mujoco.mj_mulM(model, data, column, unit)
        inertia = max(inertia, float(column[dof]))
    span = float(hi - lo)
    # beat gravity and dry friction, then cross the range in about a second
    return (
        2.0 * worst
        + 3.0 * float(model.dof_frictionloss[dof])
        + 4.0 * inertia * span
        + 2.0 * float(model.dof_damping[dof]) * span
    )


def validate_asset(path: Path, category: str | None = None, *, physics: bool = True) -> AssetReport:
    """Run every check on one asset file and collect all problems (never raises for bad assets)."""
    t0 = time.perf_counter()
    report = AssetReport(path.stem, path)
    try:
        stage = open_stage(path)
    except AssetError as exc:
        report.problems.append(str(exc))
        report.seconds = time.perf_counter() - t0
        return report
    report.problems += usd_problems(stage)
    report.problems += semantic_problems(stage, category)
    try:
        load_asset_spec(path).compile()
    except Exception as exc:
        report.problems.append(f"mujoco: does not compile: {exc}".replace(f"{path.stem}: ", ""))
        report.seconds = time.perf_counter() - t0
        return report
    if physics:
        try:
            if _attr(stage, "static", False):
                problems, metrics = sweep_joints(path)
            else:
                problems, metrics = settle_free(
                    path, _attr(stage, "rest_quat", (1, 0, 0, 0)), bool(_attr(stage, "upright", True))
                )
        except Exception as exc:
            problems, metrics = [f"physics: test scene failed: {exc}"], {}
        report.problems += problems
        report.metrics.update(metrics)
    report.seconds = time.perf_counter() - t0
    return report
