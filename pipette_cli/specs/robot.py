"""Robot facts: one YAML file per robot under ``registry/robots/``, the only home of robot numbers.

Every module that needs a robot's joints, home pose, gripper mapping, tool centre point, reach or
payload reads it from here (``robot_spec("franka_panda")``); nothing else writes those literals.
Adding a robot is a new file here plus its ``mujoco_menagerie`` folder (docs/robots.md).

The tool centre point (tcp) is given in the end-effector body's frame together with two of its axes
(``approach``: the direction the fingers point; ``closing``: the direction the fingers close along).
Pipette builds a site ``tcp`` whose frame is canonical on every robot: z along ``approach``,
y along ``closing``, so skills and teleoperation are written once for all robots.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, ValidationError, model_validator

from pipette_cli.errors import SpecError, suggest
from pipette_cli.resources import data_dir
from pipette_cli.specs.base import BENCH_TOP_Z, Name, Spec, Vec3
from pipette_cli.specs.yaml_io import read_yaml, to_plain, validation_problems

Axis = Literal["+x", "-x", "+y", "-y", "+z", "-z"]
DEFAULT_ROBOT = "franka_panda"
"""The robot of a task that names none (the paper's)."""
ROBOTS_FOLDER = "robots"
"""Sub-folder of the registry holding robot facts (never task files)."""


class MenagerieRef(Spec):
    """A model in ``mujoco_menagerie``: its folder and the XML entry (``panda`` -> ``panda.xml``)."""

    model: str
    entry: str


class AttachSpec(Spec):
    """A second menagerie model (a gripper) attached at a site of the first."""

    menagerie: MenagerieRef
    site: str
    prefix: str = Field(pattern=r"^[a-z0-9_]+/$")


class ArmSpec(Spec):
    joints: list[str] = Field(min_length=3)
    actuators: list[str] = Field(min_length=3)
    home: list[float] = Field(description="a comfortable configuration facing +x, radians")
    stow: list[float] | None = Field(
        None,
        description="a folded configuration, the hand over the base, that the robot starts in where its "
        "home pose would touch the scene (a short arm standing close to an instrument), radians",
    )
    limit_ctrl_to_joint_range: bool = False
    joint_damping: list[Annotated[float, Field(ge=0)]] | None = Field(
        None, description="passive damping of each arm joint (N m s/rad), overriding menagerie's"
    )
    kp_scale: float = Field(
        1.0,
        gt=0,
        description="factor on the stiffness kp of menagerie's arm position servos "
        "(their damping kv kept: the lag kv/kp shrinks)",
    )

    @model_validator(mode="after")
    def _lengths(self) -> ArmSpec:
        if not len(self.joints) == len(self.actuators) == len(self.home):
            raise ValueError(
                f"joints ({len(self.joints)}), actuators ({len(self.actuators)}) and home "
                f"({len(self.home)}) must have one entry per arm joint"
            )
        if self.stow is not None and len(self.stow) != len(self.joints):
            raise ValueError(f"stow has {len(self.stow)} entries for {len(self.joints)} arm joints")
        if self.joint_damping is not None and len(self.joint_damping) != len(self.joints):
            raise ValueError(f"joint_damping has {len(self.joint_damping)} entries for {len(self.joints)} arm joints")
        return self


class DriveSpec(Spec):
    """The gripper actuator's position servo gains and force limit, overriding menagerie's (gains
    left out keep menagerie's, for actuators whose control is not a joint position)."""

    kp: float | None = Field(None, gt=0)
    kv: float | None = Field(None, ge=0)
    force: float = Field(gt=0, description="the actuator's force limit (newtons, or its own units)")


class GripperSpec(Spec):
    actuator: str
    joint: str = Field(description="joint whose position is the gripper state g_t")
    open_ctrl: float = Field(description="actuator control for the binary command u = 1 (open)")
    closed_ctrl: float = Field(description="actuator control for u = 0 (closed)")
    max_opening: float = Field(gt=0, lt=0.3, description="metres between the fingertips, fully open")
    finger_depth: float = Field(gt=0, lt=0.2, description="metres from the tcp up to the palm")
    fingertip: float = Field(ge=0, lt=0.05, description="metres the fingertips reach beyond the tcp")
    finger_thickness: float = Field(
        gt=0, lt=0.05, description="metres across a fingertip, perpendicular to closing and approach"
    )
    torsional_friction: float = Field(
        0.01,
        gt=0,
        lt=0.2,
        description="metres: how strongly the finger contacts resist a held object turning about their "
        "normal (MuJoCo's torsional friction); more where a finger is one thin plate, whose contact with "
        "a cylinder is a line that lets a pinched pipette turn in the fingers",
    )
    drive: DriveSpec | None = None
    pad: PadSpec | None = None


class PadSpec(Spec):
    """A flat box added to each finger over its contact face: where menagerie's fingertip is a row of
    small boxes with grooves between them (the Panda's: 5 mm wide, 1.5 mm deep), a 10-15 mm neck or
    tube nests in a groove, pinched from both sides of it, and stays stuck when the fingers open."""

    bodies: list[str] = Field(min_length=1, description="the finger bodies (each gets the box in its own frame)")
    pos: Vec3 = Field(description="the box's centre in each finger body's frame (metres)")
    half: Vec3 = Field(description="the box's half sizes (metres)")
    rows: int = Field(
        3,
        ge=1,
        le=8,
        description="boxes the face is split into along the finger's length (z): MuJoCo gives a cylinder "
        "touching a box one contact point, about which a held tube or neck pivots; a row each makes a line",
    )


class TcpSpec(Spec):
    pos: Vec3
    approach: Axis = "+z"
    closing: Axis = "+y"

    @model_validator(mode="after")
    def _orthogonal(self) -> TcpSpec:
        if self.approach[1] == self.closing[1]:
            raise ValueError(f"approach ({self.approach}) and closing ({self.closing}) must be different axes")
        return self

    def rotation(self) -> np.ndarray:
        """3x3 rotation of the canonical tcp frame (z approach, y closing) in the end-effector body."""
        z, y = _axis(self.approach), _axis(self.closing)
        return np.column_stack([np.cross(y, z), y, z])


class WristCameraSpec(Spec):
    """The wrist camera's pose in the canonical hand frame (the tcp frame's axes at the camera body's
    origin) and field of view: a task run on this robot gets it unless the task is authored for it."""

    pos: Vec3
    euler_deg: Vec3
    fovy_deg: float = Field(70.0, gt=0, lt=180)


class EndEffectorSpec(Spec):
    body: str
    tcp: TcpSpec
    wrist_camera_body: str


class WorkspaceSpec(Spec):
    """Where ``pipette new-task`` lays objects out for this robot: a band of comfortable distances
    from the base axis, the preferred distance of the work area and the lateral lane of its parts."""

    center_x: float = Field(gt=0)
    lane_y: float = Field(gt=0)
    min_reach: float = Field(gt=0)
    max_reach: float = Field(gt=0)


class RobotSpec(Spec):
    """Everything Pipette knows about one robot."""

    name: Name
    aliases: list[Name] = Field([], description="other ids; the first is the short name (`--robot piper`, tags)")
    words: list[str] = Field([], description="phrases that name the robot in a task description, longest first")
    description: str = ""
    menagerie: MenagerieRef
    attach: AttachSpec | None = None
    arm: ArmSpec
    gripper: GripperSpec
    end_effector: EndEffectorSpec
    wrist_camera: WristCameraSpec
    base_height: float = Field(BENCH_TOP_Z, description="default base height: the bench top")
    footprint_radius: float = Field(gt=0, lt=0.5, description="metres around the base axis kept clear of objects")
    reach: float = Field(
        gt=0,
        description="metres from the base axis for a grasp 10 cm over the bench top, the hand "
        "tilted 30 deg from the vertical",
    )
    top_down_reach: float = Field(
        gt=0,
        description="metres from the base axis for a grasp 10 cm over the bench top, the hand pointing straight down",
    )
    min_reach: float = Field(ge=0, description="closer than this the arm folds onto itself")
    payload_kg: float = Field(gt=0)
    workspace: WorkspaceSpec

    @property
    def arm_dof(self) -> int:
        return len(self.arm.joints)

    @property
    def arm_joints(self) -> tuple[str, ...]:
        return tuple(self.arm.joints)

    @property
    def arm_actuators(self) -> tuple[str, ...]:
        return tuple(self.arm.actuators)

    def home(self) -> np.ndarray:
        return np.asarray(self.arm.home, dtype=float)

    def gripper_ctrl(self, command: float) -> float:
        """Actuator control for a binary gripper command: open when ``command >= 0.5`` (paper A.6)."""
        return self.gripper.open_ctrl if command >= 0.5 else self.gripper.closed_ctrl

    def state_names(self) -> list[str]:
        """Names of the state vector's entries: the arm joints' positions, then the gripper joint's."""
        return [*self.arm.joints, "gripper"]

    def action_names(self) -> list[str]:
        """Names of the action vector's entries: arm joint targets, then the binary gripper command."""
        return [f"{joint}_target" for joint in self.arm.joints] + ["gripper_open"]


def _axis(name: str) -> np.ndarray:
    out = np.zeros(3)
    out["xyz".index(name[1])] = 1.0 if name[0] == "+" else -1.0
    return out


def robots_dir() -> Path:
    return data_dir("registry") / ROBOTS_FOLDER


@cache
def load_robot_specs() -> dict[str, RobotSpec]:
    """Every robot in ``registry/robots/``, by name.

    Raises:
        SpecError: a file does not validate (``file:line: field: message``), or two robots share a
            name or alias.
    """
    robots: dict[str, RobotSpec] = {}
    owner: dict[str, Path] = {}
    problems: list[str] = []
    for path in sorted(robots_dir().glob("*.yaml")):
        doc = read_yaml(path)
        raw = to_plain(doc)
        try:
            spec = RobotSpec.model_validate(raw)
        except ValidationError as exc:
            problems.extend(validation_problems(exc, RobotSpec, raw, doc, str(path)))
            continue
        for key in (spec.name, *spec.aliases):
            if key in owner:
                problems.append(f"{path}: robot name {key!r} is already used by {owner[key]}")
            owner[key] = path
        robots[spec.name] = spec
    if problems:
        raise SpecError(problems)
    return robots


def robot_names() -> list[str]:
    return sorted(load_robot_specs())


def robot_words() -> dict[str, list[str]]:
    """Robot id -> every way people name it, longest first: its id (also with spaces), its
    ``aliases`` and its ``words`` ("the UR5e", "universal robots"). The one home of robot names
    for every language front-end (`pipette agent`, `pipette new-task`)."""
    return {
        name: sorted(
            {name, name.replace("_", " "), *spec.aliases, *(a.replace("_", " ") for a in spec.aliases), *spec.words},
            key=len,
            reverse=True,
        )
        for name, spec in load_robot_specs().items()
    }


def robot_spec(name: str) -> RobotSpec:
    """The robot called ``name`` (or one of its aliases).

    Raises:
        SpecError: unknown robot, listing the known ones with a close match.
    """
    robots = load_robot_specs()
    if name in robots:
        return robots[name]
    for spec in robots.values():
        if name in spec.aliases:
            return spec
    keys = [*robots, *(a for s in robots.values() for a in s.aliases)]
    hint = suggest(name, keys)
    known = ", ".join(f"{key} ({robots[key].aliases[0]})" if robots[key].aliases else key for key in sorted(robots))
    raise SpecError(
        f"unknown robot {name!r}; {hint}" + ("" if hint.startswith("valid names") else f" (robots: {known})")
    )
