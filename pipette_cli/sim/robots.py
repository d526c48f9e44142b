"""The three embodiments, loaded from ``mujoco_menagerie`` and prepared for Pipette.

Each robot becomes an ``MjSpec`` with: position-controlled arm joints, one gripper actuator
driven by a binary command (u = 1 open, u = 0 closed, paper A.3), a ``tcp`` site between the
fingertips (the IK target and the gripper's sensing point), and a ``wrist_mount`` frame where
the wrist camera goes. Offline machines set ``MENAGERIE_ROOT`` (see mujoco_menagerie).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from pipette_cli.errors import SimError, suggest

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RobotConfig:
    """Names and numbers that differ between embodiments (inside the robot's own spec)."""

    name: str
    menagerie: str
    entry: str
    arm_joints: tuple[str, ...]
    arm_actuators: tuple[str, ...]
    gripper_actuator: str
    gripper_joint: str
    """Joint whose position is the gripper state g_t (one finger of the gripper)."""
    gripper_open: float
    """Gripper actuator control for u = 1 (open)."""
    gripper_closed: float
    """Gripper actuator control for u = 0 (closed)."""
    ee_body: str
    tcp_pos: tuple[float, float, float]
    """Tool centre point in the ee body's frame: between the fingertips."""
    wrist_camera_body: str

    @property
    def arm_dof(self) -> int:
        return len(self.arm_joints)


PANDA = RobotConfig(
    name="franka_panda",
    menagerie="franka_emika_panda",
    entry="panda",
    arm_joints=tuple(f"joint{i}" for i in range(1, 8)),
    arm_actuators=tuple(f"actuator{i}" for i in range(1, 8)),
    gripper_actuator="actuator8",
    gripper_joint="finger_joint1",
    gripper_open=0.04,  # paper A.5: finger targets 0.04 m open, 0 closed
    gripper_closed=0.0,
    ee_body="hand",
    tcp_pos=(0.0, 0.0, 0.1034),
    wrist_camera_body="hand",
)
PIPER = RobotConfig(
    name="agilex_piper",
    menagerie="agilex_piper",
    entry="piper",
    arm_joints=tuple(f"joint{i}" for i in range(1, 7)),
    arm_actuators=tuple(f"joint{i}" for i in range(1, 7)),
    gripper_actuator="gripper",
    gripper_joint="joint7",
    gripper_open=0.035,
    gripper_closed=0.0,
    ee_body="link6",
    tcp_pos=(0.0, 0.0, 0.135),
    wrist_camera_body="link6",
)
UR5E_ROBOTIQ = RobotConfig(
    name="ur5e_robotiq",
    menagerie="universal_robots_ur5e",
    entry="ur5e",
    arm_joints=(
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ),
    arm_actuators=("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3"),
    gripper_actuator="gripper/fingers_actuator",
    gripper_joint="gripper/right_driver_joint",
    gripper_open=0.0,  # Robotiq 2F-85: control 0 open, 255 closed
    gripper_closed=255.0,
    ee_body="wrist_3_link",
    tcp_pos=(0.0, 0.1, 0.0),
    wrist_camera_body="wrist_3_link",
)
ROBOTS: dict[str, RobotConfig] = {r.name: r for r in (PANDA, PIPER, UR5E_ROBOTIQ)}

# Gripper drive for the Panda: paper A.5's stiffness 1e4 and damping 1e3 (stable at 600 Hz with
# implicitfast). The damping also sets the closing speed (~0.1 s time constant): faster fingers
# knock light tubes away. The paper's effort 1000 is PhysX's; 100 N on the tendon holds every
# benchmark object without crushing the contacts (scripted-expert sweep, docs/experts.md).
PANDA_GRIPPER_KP = 1.0e4
PANDA_GRIPPER_KV = 1.0e3
PANDA_GRIPPER_FORCE = 100.0
PIPER_GRIPPER_KP = 2.0e3
PIPER_GRIPPER_KV = 1.0e2
PIPER_GRIPPER_FORCE = 30.0


def robot_config(name: str) -> RobotConfig:
    """The :class:`RobotConfig` called ``name``.

    Raises:
        SimError: unknown robot, with the known ones.
    """
    try:
        return ROBOTS[name]
    except KeyError:
        raise SimError(f"unknown robot {name!r}; {suggest(name, ROBOTS)}") from None


def _menagerie_spec(menagerie: str, entry: str) -> mujoco.MjSpec:
    import mujoco_menagerie

    try:
        spec = mujoco_menagerie.get(menagerie).spec(entry)
    except Exception as exc:
        raise SimError(
            f"cannot load robot {menagerie!r} from mujoco_menagerie ({exc}); offline machines must set "
            "MENAGERIE_ROOT to a local menagerie checkout"
        ) from exc
    # agilex_piper names some meshes "./assets/x.obj" under meshdir="assets", which resolves
    # to "assets/assets/x.obj". Point those at the file that exists.
    base = Path(spec.modelfiledir)
    for mesh in spec.meshes:
        if spec.meshdir and not (base / spec.meshdir / mesh.file).exists() and (base / mesh.file).exists():
            mesh.file = str(Path(mesh.file).relative_to(spec.meshdir))
    return spec


def make_robot_spec(name: str) -> tuple[mujoco.MjSpec, RobotConfig]:
    """A fresh, editable spec of robot ``name`` ready to be attached into a scene."""
    config = robot_config(name)
    spec = _menagerie_spec(config.menagerie, config.entry)
    for key in list(spec.keys):
        spec.delete(key)  # keyframes would not match the composed scene's qpos
    for root in spec.worldbody.bodies:
        root.pos = [0.0, 0.0, 0.0]  # the task's embodiment.base places the robot (piper.xml offsets its root)
        root.quat = [1.0, 0.0, 0.0, 0.0]
    if config.name == "ur5e_robotiq":
        gripper = _menagerie_spec("robotiq_2f85", "2f85")
        for key in list(gripper.keys):
            gripper.delete(key)
        spec.attach(gripper, prefix="gripper/", site=spec.site("attachment_site"))
    if config.name == "franka_panda":
        act = spec.actuator(config.gripper_actuator)
        act.gainprm[0] = PANDA_GRIPPER_KP
        act.biasprm[:3] = [0.0, -PANDA_GRIPPER_KP, -PANDA_GRIPPER_KV]
        act.ctrlrange = [config.gripper_closed, config.gripper_open]
        act.forcerange = [-PANDA_GRIPPER_FORCE, PANDA_GRIPPER_FORCE]
    if config.name == "agilex_piper":
        for act_name in (*config.arm_actuators, config.gripper_actuator):
            act = spec.actuator(act_name)
            joint = spec.joint(act.target)
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.ctrlrange = joint.range
        # menagerie's finger servo (kp 40 N/m) squeezes with under 1 N: too weak to lift a flask
        act = spec.actuator(config.gripper_actuator)
        act.gainprm[0] = PIPER_GRIPPER_KP
        act.biasprm[:3] = [0.0, -PIPER_GRIPPER_KP, -PIPER_GRIPPER_KV]
        act.forcerange = [-PIPER_GRIPPER_FORCE, PIPER_GRIPPER_FORCE]
    _stiffen_fingers(spec, config)
    ee = spec.body(config.ee_body)
    if ee is None:
        raise SimError(f"robot {name!r}: end-effector body {config.ee_body!r} not found in the menagerie model")
    ee.add_site(name="tcp", pos=list(config.tcp_pos), size=[0.006, 0, 0], rgba=[1, 0.2, 0.2, 0.0], group=4)
    return spec, config


FINGER_SOLREF = (0.005, 1.0)
FINGER_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)


def _stiffen_fingers(spec: mujoco.MjSpec, config: RobotConfig) -> None:
    """Stiff, high-friction contacts on the gripper so a grasp holds without sinking in.

    MuJoCo's default contact (solref 0.02 s) lets a 100 N grip press several millimetres into
    a tube; 5 ms (>= 2 physics steps at 600 Hz) keeps it under a millimetre.
    """
    ee = spec.body(config.ee_body)
    stack = [ee]
    while stack:
        body = stack.pop()
        for geom in body.geoms:
            if geom.contype or geom.conaffinity:
                geom.solref = list(FINGER_SOLREF)
                geom.solimp = list(FINGER_SOLIMP)
                geom.friction = [1.5, 0.01, 0.001]
                geom.condim = 4
                geom.priority = 1  # these parameters win over the touched object's (no averaging)
        stack.extend(body.bodies)


def gripper_ctrl(config: RobotConfig, command: float) -> float:
    """Actuator control for a gripper command: open when command >= 0.5 (paper A.6)."""
    return config.gripper_open if command >= 0.5 else config.gripper_closed


def home_joints(name: str) -> np.ndarray:
    """A comfortable arm configuration facing +x, used when a task gives none."""
    return {
        "franka_panda": np.array([0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785]),
        "agilex_piper": np.array([0.0, 1.4, -1.5, 0.0, 1.2, 0.0]),
        "ur5e_robotiq": np.array([0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0]),
    }[robot_config(name).name]
