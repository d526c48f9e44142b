"""What the agent proposes: one command of the CLI with parameter values, or what is missing."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

Value = str | int | float | bool | list[str]


class CommandPlanSpec(BaseModel):
    """One ``pipette`` command as structured data (what an LLM backend must answer with)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    command: str = Field(description="a command of the CLI, e.g. 'collect' or 'data inspect'")
    params: dict[str, Value] = Field(default_factory=dict, description="parameter name -> value")
    missing: list[str] = Field(default_factory=list, description="required values the request does not give")
    notes: list[str] = Field(default_factory=list, description="defaults filled in, assumptions")


class Suggestion(BaseModel):
    """A request naming something unknown: the closest known names."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    what: str
    given: str
    closest: list[str]


def describe(plan: CommandPlanSpec) -> dict[str, Any]:
    return plan.model_dump()
