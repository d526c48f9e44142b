"""What a backend produces from a description: a :class:`TaskDraftSpec`, never YAML or code.

An LLM fills this model through JSON-schema structured output (:func:`pipette_cli.llm.strict_json_schema`);
the offline parser fills it by parsing. Deterministic code (:mod:`.compose`) then checks it
against the asset library, lays the scene out and renders the registry YAML.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, model_validator

from pipette_cli.errors import SpecError
from pipette_cli.specs.base import Spec
from pipette_cli.specs.robot import robot_names

Robot = Literal.__getitem__(tuple(robot_names()))  # the robots of registry/robots/, as an enum for the LLM schema

Intent = Literal["pick", "place", "insert", "open", "close", "press", "transfer", "position"]
INTENTS: tuple[str, ...] = ("pick", "place", "insert", "open", "close", "press", "transfer", "position")
Role = Literal["item", "destination", "source", "instrument", "target", "distractor"]
AssetId = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=64, description="an asset id from the library")]

ROLES_BY_INTENT: dict[str, dict[str, tuple[int, int]]] = {
    # role -> (min count, max count); distractors are allowed everywhere (up to 2)
    "pick": {"item": (1, 1), "source": (0, 1)},
    "place": {"item": (1, 1), "destination": (1, 1), "source": (0, 1)},
    "insert": {"item": (1, 1), "destination": (1, 1), "source": (0, 1)},
    "transfer": {"item": (1, 1), "source": (1, 1), "destination": (0, 1)},
    "position": {"item": (1, 1), "target": (1, 1)},
    "open": {"instrument": (1, 1)},
    "close": {"instrument": (1, 1)},
    "press": {"instrument": (1, 1)},
}


class DraftError(SpecError):
    """A draft that cannot become a task: unknown objects, contradictions, impossible layouts.

    ``problems`` holds one sentence per problem; each says what to change.
    """


class DraftObjectSpec(Spec):
    """One object the task is about and its role in it."""

    asset: AssetId
    role: Role
    part: str | None = Field(
        None, max_length=32, description="a named part the description points at (lid, door, drawer, shelf_1, button)"
    )
    mention: str | None = Field(None, max_length=120, description="the words of the description that named it")


class DraftThresholdsSpec(Spec):
    """Optional numbers the description states; anything left null is derived from geometry."""

    lift_height_m: float | None = Field(None, ge=0.01, le=0.3)
    hold_s: float | None = Field(None, ge=0.0, le=10.0)
    timeout_s: float | None = Field(None, ge=2.0, le=120.0)
    max_tilt_deg: float | None = Field(None, ge=1.0, le=90.0)
    xy_tolerance_m: float | None = Field(None, ge=0.005, le=0.3)


class TaskDraftSpec(Spec):
    """A task described as data: intent, objects with roles, robot, thresholds, instruction."""

    intent: Intent
    objects: list[DraftObjectSpec] = Field(min_length=1, max_length=5)
    robot: Robot | None = Field(None, description="null: the default robot (franka_panda)")
    instruction: str = Field(min_length=3, max_length=300, description="one imperative sentence for the policy")
    thresholds: DraftThresholdsSpec = DraftThresholdsSpec()

    @model_validator(mode="after")
    def _roles(self) -> TaskDraftSpec:
        problems = role_problems(self)
        if problems:
            raise ValueError("; ".join(problems))
        return self

    def with_role(self, role: str) -> list[DraftObjectSpec]:
        return [o for o in self.objects if o.role == role]

    def one(self, role: str) -> DraftObjectSpec | None:
        found = self.with_role(role)
        return found[0] if found else None


def role_problems(draft: TaskDraftSpec) -> list[str]:
    """Roles the intent needs but lacks, or has too many of."""
    allowed = ROLES_BY_INTENT[draft.intent]
    problems = []
    for role, (low, high) in allowed.items():
        count = len(draft.with_role(role))
        if count < low:
            problems.append(f"intent {draft.intent!r} needs an object with role {role!r}")
        elif count > high:
            problems.append(f"intent {draft.intent!r} takes at most {high} object(s) with role {role!r}, got {count}")
    for obj in draft.objects:
        if obj.role not in allowed and obj.role != "distractor":
            problems.append(
                f"role {obj.role!r} ({obj.asset}) does not belong to intent {draft.intent!r}; "
                f"roles: {', '.join([*allowed, 'distractor'])}"
            )
    if len(draft.with_role("distractor")) > 2:
        problems.append("at most 2 distractor objects")
    return problems


