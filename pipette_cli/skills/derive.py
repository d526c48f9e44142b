"""A skill program for a task that has no ``expert:`` section, read off its success criterion.

Each criterion family maps to the skills that satisfy it: lifting an object is ``pick``; bringing it
into a region is ``pick`` + ``place_on`` (the region's disc centre, or the middle of its box on its
lower height bound); a joint bound is ``open_hinge`` / ``close_hinge`` / ``slide`` toward that
bound; a fired mechanism is ``press`` on its button; a point near a target is ``pick`` +
``position_over``; a displacement is ``pick`` + ``move``; a ``sequence`` is its stages' programs in
order and ``all`` its children's. What none of these covers raises :class:`CannotDerive`, naming
the criterion, so the task author writes the program.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pipette_cli.errors import PipetteError
from pipette_cli.plugins import Plugins
from pipette_cli.specs import evaluators as ev
from pipette_cli.specs.base import BENCH_TOP_Z
from pipette_cli.specs.expert import (
    CloseHingeSpec,
    MoveSpec,
    OpenHingeSpec,
    PickSpec,
    PlaceOnSpec,
    PositionOverSpec,
    PressSpec,
    SlideSpec,
    StepSpec,
    TargetSpec,
)
from pipette_cli.specs.task import TaskSpec


class CannotDerive(PipetteError):
    """No skill program can be read off this success criterion; write an ``expert:`` section."""


Deriver = Callable[[TaskSpec, Any], list[StepSpec]]  # (task, its criterion of the registered type)
DERIVERS: Plugins[Deriver] = Plugins("program deriver", CannotDerive)


def deriver(*types: str) -> Callable[[Deriver], Deriver]:
    """Register how programs are read off criteria of the given ``type`` names."""
    return DERIVERS.register(*types)


def derive_program(task: TaskSpec) -> list[StepSpec]:
    """The task's program: its own ``expert:`` section, else one read off its success criterion.

    Raises:
        CannotDerive: the criterion (or one of its stages) has no skill that satisfies it.
    """
    if task.expert:
        return list(task.expert)
    return _steps(task, task.success)


def _steps(task: TaskSpec, spec: ev.EvaluatorSpec) -> list[StepSpec]:
    fn = DERIVERS.find(spec.type)
    if fn is None:
        raise CannotDerive(
            f"{task.id}: no expert program can be read off a {spec.type!r} criterion; "
            "give the task an 'expert:' section (docs/extending/adding_a_task.md)"
        )
    return fn(task, spec)


def _held(task: TaskSpec, name: str) -> str:
    return name.split("/", 1)[0]


@deriver("lift_and_hold")
def _lift(task: TaskSpec, spec: ev.LiftAndHoldSpec) -> list[StepSpec]:
    return [
        PickSpec(object=_held(task, spec.object), lift=max(0.08, spec.min_height_gain + 0.05), hold_s=spec.hold_s + 0.5)
    ]


@deriver("region_hold", "stable_placement")
def _region(task: TaskSpec, spec: ev.RegionHoldSpec) -> list[StepSpec]:
    obj = _held(task, spec.object)
    if spec.within is not None:
        target: str | TargetSpec = spec.within.center
    else:
        mid = []
        for bound, axis in ((spec.x, 0), (spec.y, 1)):
            here = task.object(obj).pose.pos[axis]
            if bound is None:
                mid.append(here)
            elif bound.min is not None and bound.max is not None:
                mid.append((bound.min + bound.max) / 2)
            else:
                mid.append(bound.min + 0.04 if bound.min is not None else bound.max - 0.04)  # type: ignore[operator]
        z = spec.z.min if spec.z is not None and spec.z.min is not None else task.object(obj).pose.pos[2]
        target = TargetSpec(point=(mid[0], mid[1], z + 0.03))
    return [PickSpec(object=obj), PlaceOnSpec(object=obj, target=target)]


@deriver("joint_threshold")
def _joint(task: TaskSpec, spec: ev.JointThresholdSpec) -> list[StepSpec]:
    start = next((s.value for s in task.scene.joint_states if s.joint == spec.joint), 0.0)
    bound = spec.bound
    goal = bound.min if bound.min is not None and start < bound.min else bound.max
    if goal is None:
        goal = bound.min if bound.min is not None else 0.0
    if spec.unit == "m":
        return [SlideSpec(joint=spec.joint, to=float(goal), hold_s=spec.hold_s + 0.3)]
    # a bound toward 0 closes (assets close at 0); away from it opens
    closing = abs(goal) < abs(start)
    margin = 3.0 if goal == bound.min else -3.0
    step = CloseHingeSpec if closing else OpenHingeSpec
    return [step(joint=spec.joint, to_deg=None if closing else goal + margin, hold_s=spec.hold_s + 0.3)]


@deriver("mechanism_triggered")
def _mechanism(task: TaskSpec, spec: ev.MechanismTriggeredSpec) -> list[StepSpec]:
    mechanism = next(m for m in task.scene.mechanisms if m.name == spec.mechanism)
    button = getattr(mechanism, "button", None)
    if button is None:
        raise CannotDerive(f"{task.id}: mechanism {spec.mechanism!r} has no button to press")
    return [PressSpec(button=button, hold_s=0.5)]


@deriver("near_target")
def _near(task: TaskSpec, spec: ev.NearTargetSpec) -> list[StepSpec]:
    obj = _held(task, spec.object)
    point = spec.object if "/" in spec.object else None
    height = max(0.05, (spec.min_z or 0.0) - BENCH_TOP_Z + 0.03)
    return [
        PickSpec(object=obj),
        PositionOverSpec(object=obj, point=point, target=spec.target, height=height, hold_s=spec.hold_s + 0.5),
    ]


@deriver("displacement")
def _displacement(task: TaskSpec, spec: ev.DisplacementSpec) -> list[StepSpec]:
    obj = _held(task, spec.object)
    by = []
    for bound in (spec.delta.x, spec.delta.y, spec.delta.z):
        if bound is None:
            by.append(0.0)
        elif bound.min is not None and bound.max is not None:
            by.append((bound.min + bound.max) / 2)
        else:
            by.append(bound.min + 0.03 if bound.min is not None else bound.max - 0.03)  # type: ignore[operator]
    return [PickSpec(object=obj, lift=0.06), MoveSpec(by=(by[0], by[1], by[2]), hold_s=spec.hold_s + 0.5)]


@deriver("sequence", "all")
def _stages(task: TaskSpec, spec: ev.CompositeSpec) -> list[StepSpec]:
    steps: list[StepSpec] = []
    for child in spec.of:
        steps += _steps(task, child)
    return steps
