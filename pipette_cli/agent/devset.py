"""Development sets of requests with their expected plans, and scoring a backend on them.

A case (YAML) gives a request and what it must become: ``plan``, one line per step in the
form ``collect pipette/PickUpTestTube-v1 --out data/PickUpTestTube.h5 --episodes 20`` where
``@N`` is the output of step N; ``missing`` (step -> required values the request lacks); or
``error``, a part of the one-line refusal (an unsupported policy, an ambiguous task); and
``unused``, the request's words the plan must list as not understood (none unless given: a
plan that leaves a word unexplained without expecting it is wrong). Options
equal to the CLI's default are left out on both sides before comparing, so a plan that spells
out ``--episodes 10`` matches one that relies on it.
"""

from __future__ import annotations

import shlex
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Protocol

from pydantic import Field, TypeAdapter, ValidationError

from pipette_cli.agent.catalog import CommandCatalog, render_args
from pipette_cli.agent.plan import CheckedPlan, StepRef
from pipette_cli.errors import PipetteError, SpecError
from pipette_cli.specs.base import Spec
from pipette_cli.specs.yaml_io import make_yaml

Kind = Literal["single", "chained", "inspection", "unsupported", "missing", "error"]


class DevCaseSpec(Spec):
    request: str
    kind: Kind
    plan: list[str] = Field(default_factory=list)
    missing: dict[int, list[str]] = Field(default_factory=dict)
    error: str | None = None
    unused: list[str] = Field(default_factory=list)
    """The request's words the plan must list as not understood (none unless given)."""


class Planner(Protocol):
    name: str

    def plan(self, text: str) -> CheckedPlan: ...


def load_dev_set(path: Path) -> list[DevCaseSpec]:
    """Read a development set (a YAML list of cases).

    Raises:
        SpecError: the file is unreadable or a case is malformed (with its index).
    """
    try:
        data = make_yaml().load(path.read_text(encoding="utf-8"))
        return TypeAdapter(list[DevCaseSpec]).validate_python(data)
    except (OSError, ValidationError) as exc:
        raise SpecError(f"{path}: {exc}") from None


def step_lines(plan: CheckedPlan, catalog: CommandCatalog) -> list[str]:
    """Each step as ``command args`` with ``@N`` for earlier steps' outputs."""

    def show(value: Any) -> Any:
        if isinstance(value, StepRef):
            return f"@{value.from_step}"
        return [show(v) for v in value] if isinstance(value, list) else value

    lines = []
    for step in plan.steps:
        info = catalog.get(step.command)
        lines.append(shlex.join([*info.path, *render_args(info, {k: show(v) for k, v in step.args.items()})]))
    return [canonical(line, catalog) for line in lines]


def canonical(line: str, catalog: CommandCatalog) -> str:
    """``line`` without options set to the CLI's default, options in the CLI's order."""
    words = shlex.split(line)
    name = next((" ".join(words[:n]) for n in (3, 2, 1) if " ".join(words[:n]) in catalog), None)
    if name is None:
        return line
    info = catalog.get(name)
    order = {p.name: i for i, p in enumerate(info.params.values())}
    by_flag = {p.flag: p for p in info.params.values() if p.flag}
    by_flag.update({p.off_flag: p for p in info.params.values() if p.off_flag})
    positional: list[str] = []
    options: list[tuple[int, list[str]]] = []
    i = len(info.path)
    while i < len(words):
        param = by_flag.get(words[i])
        if param is not None and param.is_flag:
            if (words[i] == param.flag) != bool(param.default):
                options.append((order[param.name], [words[i]]))
            i += 1
        elif param is not None and i + 1 < len(words):
            if words[i + 1] != str(param.default):
                options.append((order[param.name], words[i : i + 2]))
            i += 2
        else:
            positional.append(words[i])
            i += 1
    options.sort(key=lambda item: item[0])
    return shlex.join([*info.path, *positional, *(w for _, pair in options for w in pair)])


@dataclass(frozen=True)
class CaseResult:
    case: DevCaseSpec
    right: bool
    got: list[str]
    missing: dict[int, list[str]]
    error: str | None
    crashed: bool
    unused: list[str]
    """The words the plan listed as not understood."""
    """A traceback, i.e. not a clean :class:`PipetteError`."""
    seconds: float


def run_case(planner: Planner, case: DevCaseSpec, catalog: CommandCatalog) -> CaseResult:
    """Plan ``case.request`` with ``planner`` and compare with the expectation."""
    started = time.perf_counter()
    got: list[str] = []
    missing: dict[int, list[str]] = {}
    unused: list[str] = []
    error, crashed = None, False
    try:
        plan = planner.plan(case.request)
        got, missing, unused = step_lines(plan, catalog), plan.missing, plan.unused
    except PipetteError as exc:
        error = str(exc)
    except Exception:
        error, crashed = traceback.format_exc(), True
    if case.error is not None:
        right = error is not None and not crashed and case.error.lower() in error.lower()
    else:
        expected = [canonical(line, catalog) for line in case.plan]
        right = error is None and got == expected and missing == case.missing and unused == case.unused
    return CaseResult(case, right, got, missing, error, crashed, unused, time.perf_counter() - started)
