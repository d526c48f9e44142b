"""Task spec -> ``MjSpec`` -> ``MjModel``: bench, assets, robot, lights and three cameras.

Everything composes through ``MjSpec.attach``: each scene object is attached with the prefix
``<name>/`` so a spec reference such as ``centrifuge/lid_hinge`` is also the MuJoCo name of
the joint. The robot is attached with prefix ``robot/``. Assets marked ``pipette:static``
are welded where they stand; the others (tools, consumables, a lift-off lid) get a free joint. The model is built once per task
with nominal poses; per-episode randomisation moves bodies at reset (:mod:`.world`).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cache

import mujoco
import numpy as np

from pipette_cli.assets.library import load_asset_library
from pipette_cli.assets.loader import attach_asset
from pipette_cli.errors import AssetError, SimError
from pipette_cli.sim.meshes import MeshDetail, decimate_visual_meshes
from pipette_cli.sim.quaternions import mat_to_quat
from pipette_cli.sim.robots import make_robot_spec, match_options, wrist_camera_pose
from pipette_cli.specs.base import BENCH_TOP_Z, PoseSpec
from pipette_cli.specs.robot import RobotSpec
from pipette_cli.specs.task import CameraSpec, TaskSpec

log = logging.getLogger(__name__)

ROBOT_PREFIX = "robot/"
BENCH_POS = (0.45, 0.0, 0.0)
"""Where the bench asset stands: its 1.6 m top spans x in [-0.35, 1.25], the robot at x = 0."""
BENCH = "bench"
"""The bench's object name: its bodies, geoms and materials are named ``bench/...``."""
FLOOR_MATERIAL = "floor_mat"
CAMERA_NAMES = ("top", "main", "wrist")
WRIST_CAMERA = ROBOT_PREFIX + "wrist"
FREE_CATEGORIES = ("tools", "consumables")
"""Categories that are free bodies when an asset does not say (its ``pipette:static`` decides)."""


@dataclass(frozen=True)
class ObjectInfo:
    """How one scene object ended up in the model."""

    name: str
    asset: str
    free: bool
    root_body: str


def euler_to_quat(euler_deg: tuple[float, float, float]) -> np.ndarray:
    """Intrinsic x-y-z Euler angles in degrees (MuJoCo's eulerseq "xyz") to a wxyz quaternion."""
    quat = np.zeros(4)
    mujoco.mju_euler2Quat(quat, np.deg2rad(np.asarray(euler_deg, dtype=float)), "xyz")
    return quat


def pose_quat(pose: PoseSpec) -> np.ndarray:
    return euler_to_quat(pose.euler_deg)


def look_at_quat(pos: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Orientation of a MuJoCo camera at ``pos`` looking at ``target`` with world +z up."""
    forward = target - pos
    norm = np.linalg.norm(forward)
    if norm < 1e-9:
        raise SimError("camera look_at equals its position")
    forward /= norm
    up = np.array([0.0, 0.0, 1.0]) if abs(forward[2]) < 0.999 else np.array([0.0, 1.0, 0.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, forward)
    return mat_to_quat(np.column_stack([right, cam_up, -forward]))  # camera x, y, z in world


def _camera_quat(cam: CameraSpec) -> np.ndarray:
    if cam.look_at is not None:
        return look_at_quat(np.asarray(cam.pos, float), np.asarray(cam.look_at, float))
    return euler_to_quat(cam.euler_deg)  # type: ignore[arg-type]


def set_physics(spec: mujoco.MjSpec, timestep: float) -> None:
    """The simulator options of every Pipette scene (and of anything measured outside one, so it
    behaves the same): implicit-fast integration, elliptic friction cones, impratio 10, gravity."""
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    spec.option.gravity = [0.0, 0.0, -9.81]


def _configure(spec: mujoco.MjSpec, task: TaskSpec) -> None:
    spec.modelname = task.short_name
    set_physics(spec, task.timing.physics_dt)
    spec.visual.global_.offwidth = max(task.cameras.width, 640)
    spec.visual.global_.offheight = max(task.cameras.height, 480)
    spec.visual.quality.shadowsize = 2048
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.35, 0.35, 0.35]
    spec.stat.center = [0.45, 0.0, 0.7]
    spec.stat.extent = 1.2


def _add_room(spec: mujoco.MjSpec) -> None:
    spec.add_texture(
        name="floor_tex",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.62, 0.64, 0.66],
        rgb2=[0.55, 0.57, 0.6],
        width=256,
        height=256,
    )
    spec.add_material(name=FLOOR_MATERIAL, textures=["", "floor_tex"], texrepeat=[8, 8], reflectance=0.05)
    spec.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.93, 0.94, 0.96],
        rgb2=[0.75, 0.78, 0.82],
        width=256,
        height=256,
    )
    world = spec.worldbody
    world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[4, 4, 0.05], material=FLOOR_MATERIAL)
    world.add_light(
        name="key", pos=[0.3, -0.8, 2.4], dir=[0.15, 0.35, -1.0], diffuse=[0.75, 0.75, 0.72], castshadow=True
    )
    world.add_light(
        name="fill", pos=[1.5, 1.0, 2.2], dir=[-0.5, -0.3, -1.0], diffuse=[0.4, 0.4, 0.42], castshadow=False
    )
    world.add_light(
        name="ceiling", pos=[0.5, 0.0, 2.6], dir=[0.0, 0.0, -1.0], diffuse=[0.3, 0.3, 0.3], castshadow=False
    )


def _attach_robot(spec: mujoco.MjSpec, task: TaskSpec) -> RobotSpec:
    robot_spec, config = make_robot_spec(task.embodiment.robot)
    match_options(robot_spec, spec)
    wrist = task.cameras.wrist
    if wrist.mount == "end_effector":
        body = robot_spec.body(config.end_effector.wrist_camera_body)
        pos, quat = wrist_camera_pose(config, wrist.pos, _camera_quat(wrist))
        body.add_camera(name="wrist", pos=pos, quat=quat, fovy=wrist.fovy_deg)
    base = task.embodiment.base
    frame = spec.worldbody.add_frame(pos=list(base.pos), quat=list(pose_quat(base)))
    spec.attach(robot_spec, prefix=ROBOT_PREFIX, frame=frame)
    return config


def _attach_objects(spec: mujoco.MjSpec, task: TaskSpec) -> dict[str, ObjectInfo]:
    library = load_asset_library()
    objects: dict[str, ObjectInfo] = {}
    placements = [(BENCH, task.scene.bench, PoseSpec(pos=BENCH_POS), "scene.bench")]
    placements += [(o.name, o.asset, o.pose, f"scene.objects.{i}") for i, o in enumerate(task.scene.objects)]
    for name, asset_id, pose, field in placements:
        try:
            entry = library.get(asset_id)
            free = not bool(entry.semantics().get("static", entry.category not in FREE_CATEGORIES))
            root = attach_asset(spec, asset_id, name=name, pos=pose.pos, quat=tuple(pose_quat(pose)), free_joint=free)
        except AssetError as exc:
            raise SimError(f"{task.id}: {field}: {exc}") from None
        if root is None:
            raise SimError(f"{task.id}: {field}: asset {asset_id!r} has no body")
        objects[name] = ObjectInfo(name, asset_id, free, root.name)
    return objects


def _add_cameras(spec: mujoco.MjSpec, task: TaskSpec, objects: dict[str, ObjectInfo]) -> None:
    for name in ("top", "main", "wrist"):
        cam: CameraSpec = getattr(task.cameras, name)
        if cam.mount == "end_effector":
            continue  # added to the robot before attaching
        if cam.mount == "world":
            parent = spec.worldbody
        else:
            obj, _, part = cam.mount.partition("/")
            body_name = f"{obj}/{part}" if part else objects[obj].root_body if obj in objects else cam.mount
            parent = spec.body(body_name)
            if parent is None:
                raise SimError(f"{task.id}: cameras.{name}.mount: no body {cam.mount!r} in the scene")
        parent.add_camera(name=name, pos=list(cam.pos), quat=list(_camera_quat(cam)), fovy=cam.fovy_deg)


def make_scene_spec(task: TaskSpec) -> tuple[mujoco.MjSpec, RobotSpec, dict[str, ObjectInfo]]:
    """Compose the task's scene as an editable spec (nominal poses, no randomisation)."""
    spec = mujoco.MjSpec()
    _configure(spec, task)
    _add_room(spec)
    objects = _attach_objects(spec, task)
    config = _attach_robot(spec, task)
    _add_cameras(spec, task, objects)
    return spec, config, objects


def collision_boxes(model: mujoco.MjModel, data: mujoco.MjData, geoms: Iterable[int]) -> np.ndarray:
    """World-aligned boxes (n, 6: x0, y0, z0, x1, y1, z1) around the collision geoms among ``geoms``."""
    out = []
    for g in geoms:
        if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0:
            continue
        rot = data.geom_xmat[g].reshape(3, 3)
        center = data.geom_xpos[g] + rot @ model.geom_aabb[g, :3]
        half = np.abs(rot) @ model.geom_aabb[g, 3:]
        out.append(np.concatenate([center - half, center + half]))
    return np.array(out).reshape(-1, 6)


@cache
def robot_boxes(
    robot: str, base: tuple[float, float, float] = (0.0, 0.0, BENCH_TOP_Z), joints: tuple[float, ...] | None = None
) -> np.ndarray:
    """Collision boxes (n, 6) of ``robot`` standing at ``base`` in its home pose (or arm ``joints``)."""
    spec, config = make_robot_spec(robot)
    scene = mujoco.MjSpec()
    match_options(spec, scene)
    frame = scene.worldbody.add_frame(pos=list(base))
    scene.attach(spec, prefix="r/", frame=frame)
    model = scene.compile()
    data = mujoco.MjData(model)
    for joint, value in zip(config.arm_joints, config.home() if joints is None else joints, strict=True):
        data.qpos[model.jnt_qposadr[model.joint("r/" + joint).id]] = value
    mujoco.mj_forward(model, data)
    return collision_boxes(model, data, range(model.ngeom))


def compile_scene(spec: mujoco.MjSpec, task: TaskSpec, *, meshes: MeshDetail = "full") -> mujoco.MjModel:
    """Compile, turning MuJoCo's errors into :class:`SimError` naming the task.

    ``meshes="decimated"`` swaps heavy visual-only meshes for simplified ones
    (:mod:`.meshes`, the ``fast`` render profile); the physics is that of ``"full"``.
    """
    try:
        model = spec.compile()
        if meshes == "decimated" and decimate_visual_meshes(spec, model):
            model = spec.compile()
        return model
    except Exception as exc:
        raise SimError(f"{task.id}: scene does not compile: {exc}") from None
