"""The task spec: one YAML file in ``registry/`` describes one task completely.

Frame: the bench frame — origin on the floor under the robot base, x away from the robot,
z up, bench top at z = 0.55 m. Lengths in metres, angles in degrees (joint states of the
robot in radians), times in seconds.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationInfo, field_validator, model_validator

from pipette_cli.errors import SpecError, suggest
from pipette_cli.specs.base import BENCH_TOP_Z, Name, PoseSpec, Ref, Spec, Vec3
from pipette_cli.specs.evaluators import EvaluatorField
from pipette_cli.specs.expert import StepField
from pipette_cli.specs.mechanisms import MechanismField
from pipette_cli.specs.robot import DEFAULT_ROBOT, robot_spec

TASK_ID_PATTERN = r"^[a-z][a-z0-9_]*/[A-Z][A-Za-z0-9]*-v[0-9]+$"
Category = Literal["consumable_handling", "hatch_control", "placement_relocation", "other"]


class EmbodimentSpec(Spec):
    """Which robot, where it stands, and its joint state at reset."""

    robot: str = Field(DEFAULT_ROBOT, description="a robot of registry/robots/ (name or alias)")
    base: PoseSpec = PoseSpec(pos=(0.0, 0.0, BENCH_TOP_Z))
    initial_joints: list[float] = Field(description="arm joint positions in radians")
    gripper: Literal["open", "closed"] = "open"

    @field_validator("robot")
    @classmethod
    def _known_robot(cls, name: str) -> str:
        try:
            return robot_spec(name).name  # aliases (panda, piper, ur5e) become the robot's name
        except SpecError as exc:
            raise ValueError(str(exc)) from None

    @model_validator(mode="after")
    def _dof(self) -> EmbodimentSpec:
        dof = robot_spec(self.robot).arm_dof
        if len(self.initial_joints) != dof:
            raise ValueError(f"{self.robot} has {dof} arm joints; initial_joints has {len(self.initial_joints)}")
        return self


class RandomizeSpec(Spec):
    """Uniform perturbation of an initial pose at reset: x and y in [-dx, dx], yaw in [-d, d]."""

    xy: tuple[Annotated[float, Field(ge=0)], Annotated[float, Field(ge=0)]] = (0.0, 0.0)
    yaw_deg: Annotated[float, Field(ge=0, le=180)] = 0.0


class ObjectSpec(Spec):
    """An asset placed in the scene. Tools and consumables are free bodies; equipment and
    instruments are fixed where they stand."""

    name: Name
    asset: Name
    pose: PoseSpec
    randomize: RandomizeSpec | None = None


class JointStateSpec(Spec):
    """Initial position of an articulated part (degrees for hinges, metres for slides)."""

    joint: Ref
    value: float
    randomize: Annotated[float, Field(ge=0)] = 0.0


class SceneSpec(Spec):
    """What stands on the bench at reset."""

    bench: Name = "lab_bench"
    objects: list[ObjectSpec] = Field(min_length=1)
    joint_states: list[JointStateSpec] = []
    mechanisms: list[MechanismField] = []

    @model_validator(mode="after")
    def _unique_names(self) -> SceneSpec:
        seen: set[str] = set()
        for obj in self.objects:
            if obj.name in seen:
                raise ValueError(f"object name {obj.name!r} is used twice")
            seen.add(obj.name)
        return self


class CameraSpec(Spec):
    """A camera fixed in the world, on the robot's hand (``end_effector``) or on an object body.

    Orientation from ``look_at`` (a point in the world) or ``euler_deg`` relative to the mount,
    where a zero rotation looks down the mount's -z with +y up (MuJoCo's convention).
    """

    mount: str = Field("world", pattern=r"^(world|end_effector|[a-z][a-z0-9_]*(/[A-Za-z0-9_]+)?)$")
    pos: Vec3
    look_at: Vec3 | None = None
    euler_deg: Vec3 | None = None
    fovy_deg: float = Field(45.0, gt=0, lt=180)

    @model_validator(mode="after")
    def _orientation(self) -> CameraSpec:
        if (self.look_at is None) == (self.euler_deg is None):
            raise ValueError("give exactly one of 'look_at' and 'euler_deg'")
        return self


class CamerasSpec(Spec):
    """The three views every task records (paper 3.2): top, main and wrist."""

    width: int = Field(400, ge=16, le=4096)
    height: int = Field(400, ge=16, le=4096)
    top: CameraSpec
    main: CameraSpec
    wrist: CameraSpec


class TimingSpec(Spec):
    """Rates in Hz. Physics dt = 1 / physics_hz; control runs every physics_hz / control_hz
    physics steps; a new camera frame arrives every control_hz / vision_hz control steps."""

    physics_hz: int = Field(600, gt=0)
    control_hz: int = Field(30, gt=0)
    vision_hz: int = Field(10, gt=0)

    @model_validator(mode="after")
    def _divisible(self) -> TimingSpec:
        if self.physics_hz % self.control_hz:
            raise ValueError(f"physics_hz ({self.physics_hz}) must be a multiple of control_hz ({self.control_hz})")
        if self.control_hz % self.vision_hz:
            raise ValueError(f"control_hz ({self.control_hz}) must be a multiple of vision_hz ({self.vision_hz})")
        return self

    @property
    def physics_dt(self) -> float:
        return 1.0 / self.physics_hz

    @property
    def substeps(self) -> int:
        return self.physics_hz // self.control_hz

    @property
    def vision_every(self) -> int:
        return self.control_hz // self.vision_hz


class NoteSpec(Spec):
    """A field a person must verify, and why (paper appendix B)."""

    field: str = Field(pattern=r"^[a-z_][a-z0-9_]*(\.([a-z_][a-z0-9_]*|[0-9]+))*$")
    note: str = Field(min_length=1)


class TaskSpec(Spec):
    """One task: scene, robot, cameras, instruction, targets and success criterion."""

    id: str = Field(pattern=TASK_ID_PATTERN, description="namespace/Name-vN, e.g. pipette/PickUpTestTube-v1")
    name: str = Field(min_length=1)
    category: Category
    tags: list[Annotated[str, Field(pattern=r"^[a-z0-9][a-z0-9_-]*$")]] = []
    instruction: str = Field(min_length=1, description="the language instruction given to the policy")
    description: str = ""
    embodiment: EmbodimentSpec
    scene: SceneSpec
    cameras: CamerasSpec
    timing: TimingSpec = TimingSpec()
    targets: list[Name] = Field(min_length=1, description="scene objects the task is about")
    success: EvaluatorField
    expert: list[StepField] | None = Field(
        None, min_length=1, description="the scripted expert: skill steps (default: derived from the success criterion)"
    )
    notes: list[NoteSpec] = []

    @model_validator(mode="after")
    def _references(self, info: ValidationInfo) -> TaskSpec:
        if info.context and info.context.get("defer_references"):
            return self  # the YAML loader reports these itself, with line numbers
        problems = [f"{'.'.join(map(str, loc))}: {msg}" for loc, msg in self.reference_problems()]
        if problems:
            raise ValueError("; ".join(problems))
        return self

    def reference_problems(self) -> Iterator[tuple[tuple[Any, ...], str]]:
        """Yield ``(field path, message)`` for every name that points at nothing."""
        objects = {o.name for o in self.scene.objects}
        mechanisms = {m.name for m in self.scene.mechanisms}

        def check(loc: tuple[Any, ...], ref: str) -> Iterator[tuple[tuple[Any, ...], str]]:
            head = ref.split("/", 1)[0]
            if head not in objects:
                yield loc, f"{ref!r} names no scene object; {suggest(head, objects)}"

        for i, name in enumerate(self.targets):
            yield from check(("targets", i), name)
        for i, state in enumerate(self.scene.joint_states):
            yield from check(("scene", "joint_states", i, "joint"), state.joint)
        for i, mech in enumerate(self.scene.mechanisms):
            for loc, ref in mech.refs():
                yield from check(("scene", "mechanisms", i, *loc), ref)
        for loc, ref in self.success.refs():
            yield from check(("success", *loc), ref)
        for i, step in enumerate(self.expert or []):
            for loc, ref in step.refs():
                yield from check(("expert", i, *loc), ref)
        for loc, named in _mechanism_refs(self.success, ("success",)):
            if named not in mechanisms:
                yield loc, f"mechanism {named!r} is not defined in scene.mechanisms"
        for loc in _misplaced_instructions(self.success, ("success",), stage=False):
            yield (
                loc,
                "an instruction is given to the stages of a 'sequence' only; the task's own is 'instruction' at the top",
            )
        for name, cam in (("top", self.cameras.top), ("main", self.cameras.main), ("wrist", self.cameras.wrist)):
            if cam.mount not in ("world", "end_effector"):
                yield from check(("cameras", name, "mount"), cam.mount)
        for i, note in enumerate(self.notes):
            if not _has_field(self, note.field.split(".")):
                yield ("notes", i, "field"), f"{note.field!r} is not a field of this task"

    @property
    def short_name(self) -> str:
        """``PickUpTestTube-v1`` for ``pipette/PickUpTestTube-v1``."""
        return self.id.split("/", 1)[1]

    def object(self, name: str) -> Any:
        """The scene object called ``name``."""
        for obj in self.scene.objects:
            if obj.name == name:
                return obj
        raise KeyError(name)


def _mechanism_refs(spec: Any, loc: tuple[Any, ...]) -> Iterator[tuple[tuple[Any, ...], str]]:
    mechanism = getattr(spec, "mechanism", None)
    if isinstance(mechanism, str):
        yield (*loc, "mechanism"), mechanism
    for i, child in enumerate(getattr(spec, "of", None) or []):
        yield from _mechanism_refs(child, (*loc, "of", i))


def _misplaced_instructions(spec: Any, loc: tuple[Any, ...], *, stage: bool) -> Iterator[tuple[Any, ...]]:
    if getattr(spec, "instruction", None) is not None and not stage:
        yield (*loc, "instruction")
    for i, child in enumerate(getattr(spec, "of", None) or []):
        yield from _misplaced_instructions(child, (*loc, "of", i), stage=getattr(spec, "type", None) == "sequence")


def stage_specs(task: TaskSpec) -> list[Any]:
    """The stages of a task whose criterion is a ``sequence`` (its children, in order); ``[]`` otherwise."""
    return list(getattr(task.success, "of", [])) if task.success.type == "sequence" else []


def _has_field(node: Any, parts: list[str]) -> bool:
    for part in parts:
        if isinstance(node, list | tuple):
            if not part.isdigit() or int(part) >= len(node):
                return False
            node = node[int(part)]
        elif isinstance(node, Spec):
            if part not in type(node).model_fields:
                return False
            node = getattr(node, part)
        else:
            return False
    return True
