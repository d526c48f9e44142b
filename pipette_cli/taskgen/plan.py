"""The typed plan every backend fills: objects with roles, steps (actions on them), thresholds.

The offline parser builds a :class:`TaskPlanSpec` by parsing; an LLM fills the same model through
structured output (:func:`plan_json_schema` narrows the asset field to the library's ids). From
here on both go the same way: :mod:`.validate` checks the plan against the asset library and the
robot, :mod:`.compose` lays the scene out and turns each step into a success stage and skill
steps, :mod:`.render` writes the registry YAML. Backends never write YAML or code.

A plan with one step becomes a task with that step's criterion; with several, a ``sequence``
criterion with one stage per step and the concatenated skill program.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import Field, model_validator

from pipette_cli.errors import SpecError
from pipette_cli.language.assets import Relation
from pipette_cli.llm import strict_json_schema
from pipette_cli.specs.base import Spec
from pipette_cli.specs.robot import robot_names

Action = Literal["pick", "place", "remove", "open", "close", "press", "position", "run", "tare"]
INSTRUMENT_ACTIONS = ("open", "close", "press", "run", "tare")
"""Actions on an instrument (its lid, door, drawer, buttons); the others move an object."""
BUTTON_SITES = {"run": "start_button", "tare": "tare_button"}
"""The asset site an action presses where the action is a button's (a run, a tare)."""
Role = Literal["item", "destination", "source", "instrument", "target", "distractor"]
Part = Literal[
    "lid",
    "door",
    "drawer",
    "sash",
    "button",
    "shelf_0",
    "shelf_1",
    "shelf",
    "pan",
    "platform",
    "plate",
    "block",
    "rotor",
    "slot",
]
if TYPE_CHECKING:
    type Robot = str  # the robot names are read from registry/robots/ at import time; a str to the checker
else:
    Robot = Literal.__getitem__(tuple(robot_names()))  # the robots of registry/robots/, an enum for the LLM schema
ObjectName = Annotated[
    str,
    Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=32, description="the object's name in this plan (lower_snake_case)"),
]
MAX_STEPS = 5


class PlanError(SpecError):
    """A plan (or a description) that cannot become a task. ``problems`` has one sentence per
    problem, each saying what to change; ``final`` marks refusals no rewording can fix (liquids,
    screwing caps): an LLM backend is not asked again; ``robot_limit`` marks problems that are all
    limits of the robot (reach, gripper opening, payload): another robot may do the task."""

    def __init__(self, problems: list[str] | str, *, final: bool = False, robot_limit: bool = False) -> None:
        super().__init__(problems)
        self.final = final
        self.robot_limit = robot_limit


class PlanObjectSpec(Spec):
    """One object on the bench and its role."""

    name: ObjectName
    asset: str = Field(
        min_length=2, max_length=80, description="an asset id from the library (the words naming it are resolved too)"
    )
    role: Role = Field(
        description="item: moved; destination/source: where it goes/comes from; instrument: "
        "opened, closed or pressed; target: a tool is held over it; distractor: unused"
    )


class PlanStepSpec(Spec):
    """One action: what the robot does, to which object, where."""

    action: Action
    object: ObjectName = Field(description="the object moved, or the instrument opened/closed/pressed/run")
    target: ObjectName | None = Field(None, description="place: where it goes; position: what it is held over")
    relation: Relation | None = Field(
        None, description="place: set down on the bench in this relation to the target instead of on or in it"
    )
    source: ObjectName | None = Field(None, description="where the object starts (it is taken off or out of it)")
    part: Part | None = Field(
        None,
        description="the instrument's part (lid, door, drawer, sash, button) or the "
        "target's surface (shelf_0, shelf_1)",
    )

    def required_target(self) -> str:
        """``target`` of a step that must have one (place, position).

        Raises:
            PlanError: the step has none (:func:`~pipette_cli.taskgen.validate.validate_plan`
                refuses such plans first, so this is a caller that skipped validation).
        """
        if self.target is None:
            raise PlanError(f"steps: {self.action} {self.object}: say where it goes (target)")
        return self.target


class PlanThresholdsSpec(Spec):
    """Numbers the description states; anything left null is derived from geometry."""

    lift_height_m: float | None = Field(None, ge=0.01, le=0.3)
    hold_s: float | None = Field(None, ge=0.0, le=10.0)
    timeout_s: float | None = Field(None, ge=2.0, le=120.0)
    max_tilt_deg: float | None = Field(None, ge=1.0, le=90.0)
    xy_tolerance_m: float | None = Field(None, ge=0.005, le=0.3)


class TaskPlanSpec(Spec):
    """A task as data: the objects, the steps in order, the robot, thresholds, the instruction."""

    objects: list[PlanObjectSpec] = Field(min_length=1, max_length=6)
    steps: list[PlanStepSpec] = Field(min_length=1, max_length=MAX_STEPS)
    robot: Robot | None = Field(None, description="null: the default robot (franka_panda)")
    instruction: str = Field(min_length=3, max_length=300, description="one imperative sentence for the policy")
    thresholds: PlanThresholdsSpec = PlanThresholdsSpec()

    @model_validator(mode="after")
    def _names(self) -> TaskPlanSpec:
        problems = name_problems(self)
        if problems:
            raise ValueError("; ".join(problems))
        return self

    def object(self, name: str) -> PlanObjectSpec:
        return next(o for o in self.objects if o.name == name)


def name_problems(plan: TaskPlanSpec) -> list[str]:
    """Object names used twice, and steps naming objects the plan does not have."""
    problems: list[str] = []
    names = [o.name for o in plan.objects]
    for name in sorted({n for n in names if names.count(n) > 1}):
        problems.append(f"objects: the name {name!r} is used twice; give each object its own name")
    for i, step in enumerate(plan.steps):
        for field in ("object", "target", "source"):
            value = getattr(step, field)
            if value is not None and value not in names:
                problems.append(f"steps.{i}.{field}: {value!r} is not one of the objects ({', '.join(names)})")
    return problems


def plan_json_schema(asset_ids: list[str]) -> dict[str, Any]:
    """The JSON schema sent to LLM servers: :class:`TaskPlanSpec`'s, strict, with ``asset`` an enum
    of ``asset_ids`` (servers that constrain decoding then cannot name an asset that does not exist)."""
    schema = strict_json_schema(TaskPlanSpec)
    obj = schema["$defs"]["PlanObjectSpec"]["properties"]
    obj["asset"] = {"type": "string", "enum": sorted(asset_ids), "description": obj["asset"].get("description", "")}
    return schema
