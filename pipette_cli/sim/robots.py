"""Robots from ``mujoco_menagerie``, prepared for Pipette from their facts (:mod:`pipette_cli.specs.robot`).

Each robot becomes an ``MjSpec`` with: position-controlled arm joints, one gripper actuator
driven by a binary command (u = 1 open, u = 0 closed, paper A.3), a ``tcp`` site between the
fingertips whose frame is canonical on every robot (z: the fingers' approach direction, y: the
closing direction), and the wrist camera on the robot's camera body. Offline machines set
``MENAGERIE_ROOT`` (see mujoco_menagerie).
"""

from __future__ import annotations

import logging
from pathlib import Path

import mujoco
import numpy as np

from pipette_cli.errors import SimError, SpecError
from pipette_cli.sim.quaternions import mat_to_quat
from pipette_cli.specs.robot import MenagerieRef, PadSpec, RobotSpec, robot_spec

log = logging.getLogger(__name__)

FINGER_SOLREF = (0.005, 1.0)
FINGER_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)
FINGER_FRICTION = 1.5
"""Sliding friction of the gripper's contacts (they win over the touched object's)."""


def robot_config(name: str) -> RobotSpec:
    """The facts of robot ``name`` (or an alias).

    Raises:
        SimError: unknown robot, with the known ones.
    """
    try:
        return robot_spec(name)
    except SpecError as exc:
        raise SimError(str(exc)) from None


def _menagerie_spec(ref: MenagerieRef) -> mujoco.MjSpec:
    import mujoco_menagerie  # deferred: mujoco_menagerie (~20 ms; only robots taken from the menagerie)

    try:
        robot = mujoco_menagerie.get(ref.model)
        cache = mujoco_menagerie.Cache()
        if cache.root is None and not cache.is_cached(robot):  # a download, which can take minutes to fail offline
            log.warning(
                "robot %r: first use, downloading it from mujoco_menagerie (%.0f MB); an offline machine sets "
                "MENAGERIE_ROOT to a local menagerie checkout instead",
                ref.model,
                (robot.download_size or 0) / 2**20,
            )
        spec = robot.spec(ref.entry)
    except Exception as exc:
        raise SimError(
            f"cannot load robot {ref.model!r} from mujoco_menagerie ({exc}); offline machines must set "
            "MENAGERIE_ROOT to a local menagerie checkout"
        ) from exc
    # agilex_piper names some meshes "./assets/x.obj" under meshdir="assets", which resolves
    # to "assets/assets/x.obj". Point those at the file that exists.
    base = Path(spec.modelfiledir)
    for mesh in spec.meshes:
        if spec.meshdir and not (base / spec.meshdir / mesh.file).exists() and (base / mesh.file).exists():
            mesh.file = str(Path(mesh.file).relative_to(spec.meshdir))
    for key in list(spec.keys):
        spec.delete(key)  # keyframes would not match the composed scene's qpos
    return spec


def match_options(child: mujoco.MjSpec, parent: mujoco.MjSpec) -> None:
    """Give a child spec the parent's global options so attaching raises no conflict."""
    for field in ("timestep", "integrator", "cone", "impratio", "gravity"):
        setattr(child.option, field, getattr(parent.option, field))


def make_robot_spec(name: str) -> tuple[mujoco.MjSpec, RobotSpec]:
    """A fresh, editable spec of robot ``name`` ready to be attached into a scene."""
    config = robot_config(name)
    spec = _menagerie_spec(config.menagerie)
    for root in spec.worldbody.bodies:
        root.pos = [0.0, 0.0, 0.0]  # the task's embodiment.base places the robot (piper.xml offsets its root)
        root.quat = [1.0, 0.0, 0.0, 0.0]
    if config.attach is not None:
        site = spec.site(config.attach.site)
        if site is None:
            raise SimError(
                f"robot {name!r}: no site {config.attach.site!r} to attach {config.attach.menagerie.model!r} to"
            )
        tool = _menagerie_spec(config.attach.menagerie)
        match_options(tool, spec)  # the scene sets them later; attaching raises no conflict
        spec.attach(tool, prefix=config.attach.prefix, site=site)
    if config.arm.limit_ctrl_to_joint_range:
        for act_name in (*config.arm_actuators, config.gripper.actuator):
            act = spec.actuator(act_name)
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.ctrlrange = spec.joint(act.target).range
    for act_name in config.arm_actuators if config.arm.kp_scale != 1.0 else ():
        act = spec.actuator(act_name)
        act.gainprm[0] *= config.arm.kp_scale
        act.biasprm[1] *= config.arm.kp_scale
    for joint, damping in zip(config.arm_joints, config.arm.joint_damping or (), strict=False):
        spec.joint(joint).damping = [damping, 0.0, 0.0]
    drive = config.gripper.drive
    if drive is not None:
        act = spec.actuator(config.gripper.actuator)
        if drive.kp is not None:
            act.gainprm[0] = drive.kp
            act.biasprm[:3] = [0.0, -drive.kp, -(drive.kv or 0.0)]
            tendon = spec.tendon(act.target) if act.trntype == mujoco.mjtTrn.mjTRN_TENDON else None
            if drive.kv and tendon is not None:
                # the damping on the tendon, not in the servo: a servo's damping stops counting in
                # the implicit integration once its force saturates, and the stiff, light fingers
                # chatter (they stalled half open, touching nothing, after closing fast)
                act.biasprm[2] = 0.0
                tendon.damping = [drive.kv, 0.0, 0.0]
        lo, hi = sorted((config.gripper.closed_ctrl, config.gripper.open_ctrl))
        if not config.arm.limit_ctrl_to_joint_range:
            act.ctrlrange = [lo, hi]
        act.forcerange = [-drive.force, drive.force]
    ee = spec.body(config.end_effector.body)
    if ee is None:
        raise SimError(
            f"robot {name!r}: end-effector body {config.end_effector.body!r} not found in the menagerie model"
        )
    if config.gripper.pad is not None:
        _flat_pads(spec, config.gripper.pad, name)
    _stiffen_fingers(ee, config.gripper.torsional_friction)
    _stiffen_finger_coupling(spec, ee)
    tcp = config.end_effector.tcp
    ee.add_site(
        name="tcp",
        pos=list(tcp.pos),
        quat=list(mat_to_quat(tcp.rotation())),
        size=[0.006, 0, 0],
        rgba=[1, 0.2, 0.2, 0.0],
        group=4,
    )
    return spec, config


def wrist_camera_pose(
    config: RobotSpec, pos: tuple[float, float, float], quat: np.ndarray
) -> tuple[list[float], list[float]]:
    """A wrist camera pose given in the canonical hand frame (the tcp frame's axes at the camera
    body's origin; the Panda hand's own frame), expressed in the robot's camera body."""
    rot = config.end_effector.tcp.rotation()
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, mat_to_quat(rot), np.asarray(quat, dtype=float))
    return list(rot @ np.asarray(pos, dtype=float)), list(out)


def _flat_pads(spec: mujoco.MjSpec, pad: PadSpec, robot: str) -> None:
    """Each finger of ``pad.bodies`` gets one flat face in ``pad.rows`` boxes; the model's own pad
    boxes stop colliding (the finger's mesh still does)."""
    hx, hy, hz = pad.half
    for finger in pad.bodies:
        body = spec.body(finger)
        if body is None:
            raise SimError(f"robot {robot!r}: finger body {finger!r} (gripper.pad) not found in the menagerie model")
        for geom in body.geoms:
            if geom.type == mujoco.mjtGeom.mjGEOM_BOX:
                geom.contype = geom.conaffinity = 0
        for row in range(pad.rows):
            z = pad.pos[2] - hz + (2 * row + 1) * hz / pad.rows
            body.add_geom(
                name=f"{finger}_pad_{row}",
                type=mujoco.mjtGeom.mjGEOM_BOX,
                pos=[pad.pos[0], pad.pos[1], z],
                size=[hx, hy, hz / pad.rows],
                group=3,
            )


def _stiffen_fingers(ee: mujoco.MjsBody, torsional: float) -> None:
    """Stiff, high-friction contacts on the gripper so a grasp holds without sinking in, resisting
    twist about their normal by ``torsional`` metres (the robot's ``gripper.torsional_friction``).

    MuJoCo's default contact (solref 0.02 s) lets a 100 N grip press several millimetres into
    a tube; 5 ms (>= 2 physics steps at 600 Hz) keeps it under a millimetre.
    """
    stack = [ee]
    while stack:
        body = stack.pop()
        for geom in body.geoms:
            if geom.contype or geom.conaffinity:
                geom.solref = list(FINGER_SOLREF)
                geom.solimp = list(FINGER_SOLIMP)
                geom.friction = [FINGER_FRICTION, torsional, 0.001]
                geom.condim = 4
                geom.priority = 1  # these parameters win over the touched object's (no averaging)
        stack.extend(body.bodies)


def _stiffen_finger_coupling(spec: mujoco.MjSpec, ee: mujoco.MjsBody) -> None:
    """The equality constraints that tie a gripper's fingers together, as stiff as its contacts.

    With MuJoCo's default (solref 0.02 s), the Piper's second finger, which follows the driven one
    through a joint equality, gave way under about 1 N per millimetre: its servo's 30 N squeezed a
    pipette with 3 N per contact, pushed to one side, and it pivoted out of the fingers within seconds
    once held upright. The Panda's and the UR5e's menagerie models already use these parameters.
    """
    bodies: set[str] = set()
    joints: set[str] = set()
    stack = [ee]
    while stack:
        body = stack.pop()
        bodies.add(body.name)
        joints.update(j.name for j in body.joints)
        stack.extend(body.bodies)
    for eq in spec.equalities:
        names = {eq.name1, eq.name2} - {""}
        inside = joints if eq.type == mujoco.mjtEq.mjEQ_JOINT else bodies
        if eq.type in (mujoco.mjtEq.mjEQ_JOINT, mujoco.mjtEq.mjEQ_CONNECT) and names and names <= inside:
            eq.solref = list(FINGER_SOLREF)
            eq.solimp = list(FINGER_SOLIMP)


def gripper_ctrl(config: RobotSpec, command: float) -> float:
    """Actuator control for a gripper command: open when command >= 0.5 (paper A.6)."""
    return config.gripper_ctrl(command)


def home_joints(name: str) -> np.ndarray:
    """The robot's home configuration (facing +x), used when a task gives none."""
    return robot_config(name).home()
