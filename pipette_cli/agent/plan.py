"""What the agent proposes: an ordered list of commands with arguments (:class:`PlanSpec`).

The offline parser and the LLM backends fill this same model; :func:`.validate.check_plan`
turns it into a :class:`CheckedPlan` (values typed and checked against the CLI's catalog,
defaults and earlier steps' outputs filled in, what is still missing listed). A step takes
an earlier step's output with ``{"from_step": N}`` as an argument value; it becomes that
step's output path (the file ``collect --out`` writes, the folder ``train`` fills...).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pydantic import Field

from pipette_cli.specs.base import Spec


class StepRef(Spec):
    """The output of an earlier step of the same plan (1-based)."""

    from_step: int = Field(ge=1, description="the step whose output this value is")


Scalar = str | int | float | bool
Value = Scalar | StepRef | list[Scalar | StepRef]


class StepSpec(Spec):
    """One ``pipette`` command: its name and its parameters by name."""

    command: str = Field(description="a command of the catalog, e.g. 'collect' or 'data inspect'")
    args: dict[str, Value] = Field(default_factory=dict, description="parameter name -> value")


class PlanSpec(Spec):
    """The commands a request asks for, in order (what an LLM backend must answer with)."""

    steps: list[StepSpec] = Field(min_length=1, max_length=12)


@dataclass(frozen=True)
class CheckedStep:
    """A step as the validator left it: typed values, defaults filled, what is missing."""

    index: int
    """1-based position in the plan."""
    command: str
    args: dict[str, Any]
    """Typed values; :class:`StepRef` where an earlier step's output goes."""
    missing: list[str] = field(default_factory=list)
    product: str | None = None
    """The file or folder this step makes, if any (what a later ``from_step`` means)."""
    product_kind: str | None = None
    notes: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class CheckedPlan:
    """A validated plan; only such a plan is ever shown as runnable or run."""

    steps: list[CheckedStep]
    request: str = ""
    unused: list[str] = field(default_factory=list)
    """Words of the request the plan does not use (not understood), in order; a plan with any
    is shown with them and never run without asking (see :mod:`.accounting`)."""

    @property
    def missing(self) -> dict[int, list[str]]:
        return {s.index: s.missing for s in self.steps if s.missing}

    @property
    def runnable(self) -> bool:
        return not self.missing

    def resolved_args(self, step: CheckedStep) -> dict[str, Any]:
        """``step.args`` with every :class:`StepRef` replaced by that step's output path."""

        def value(v: Any) -> Any:
            if isinstance(v, StepRef):
                return self.steps[v.from_step - 1].product
            if isinstance(v, list):
                return [value(x) for x in v]
            return v

        return {k: value(v) for k, v in step.args.items()}

    def spec(self) -> PlanSpec:
        """The plan as the typed model (e.g. to store or hand to another tool)."""
        return PlanSpec(steps=[StepSpec(command=s.command, args=s.args) for s in self.steps])


def plain(value: Any) -> Any:
    """A value as JSON data (``StepRef`` -> ``{"from_step": N}``)."""
    if isinstance(value, StepRef):
        return value.model_dump()
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


@dataclass
class Context:
    """What an interactive session remembers between requests ("now render it")."""

    task: str | None = None
    products: dict[str, str] = field(default_factory=dict)
    """Kind (``demos``, ``dataset``, ``policy``...) -> the last such output a plan named."""

    def remember(self, plan: CheckedPlan) -> None:
        for step in plan.steps:
            if step.product and step.product_kind:
                self.products[step.product_kind] = step.product
            task = step.args.get("task_id") or step.args.get("tasks")
            if isinstance(task, str) and task != "all" and "," not in task:
                self.task = task
            elif isinstance(task, list) and len(task) == 1:
                self.task = task[0]
