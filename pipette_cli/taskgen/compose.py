"""A checked plan -> a :class:`ComposedTask`: the laid-out scene (:mod:`.scene`), one stage per
step (:mod:`.stages`), the success criterion (the stage's, or a ``sequence`` of them) and the
expert program (the stages' skill steps in order), the task's id, name, cameras and notes.

Everything here is deterministic and typed: criteria are evaluator specs, programs are expert
step specs, so what reaches the template has already been validated field by field.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from pipette_cli.specs import evaluators as ev
from pipette_cli.specs.expert import InsertIntoSpec, PickSpec, PlaceOnSpec, RemoveFromSpec, StepSpec
from pipette_cli.specs.mechanisms import InstrumentSpec, MechanismSpec
from pipette_cli.specs.robot import DEFAULT_ROBOT, robot_spec
from pipette_cli.taskgen.layout import PlacedObject
from pipette_cli.taskgen.measure import r
from pipette_cli.taskgen.naming import stage_instruction, step_name
from pipette_cli.taskgen.naming import task_id as derive_id
from pipette_cli.taskgen.plan import PlanError
from pipette_cli.taskgen.scene import SceneBuilder
from pipette_cli.taskgen.stages import Stage, StageBuilder
from pipette_cli.taskgen.validate import CheckedPlan

CATEGORY = {
    "pick": "consumable_handling",
    "position": "consumable_handling",
    "place": "placement_relocation",
    "remove": "placement_relocation",
    "open": "hatch_control",
    "close": "hatch_control",
    "press": "hatch_control",
    "run": "other",
    "tare": "other",
}


@dataclass
class ComposedTask:
    """Everything the task template needs; built by :func:`compose`."""

    task_id: str
    name: str
    category: str
    tags: list[str]
    instruction: str
    robot: str
    initial_joints: list[float]
    objects: list[PlacedObject]
    joint_states: list[tuple[str, float, str]]
    mechanisms: list[MechanismSpec]
    targets: list[str]
    stages: list[Stage]
    success: ev.EvaluatorSpec
    program: list[StepSpec]
    comments: dict[str, str]
    notes: list[tuple[str, str]]
    cameras: dict[str, dict[str, Any]]
    checked: CheckedPlan = field(repr=False)
    starts: dict[str, str] = field(default_factory=dict)
    """Object -> the object it starts in or on (a source, or a rack the layout added)."""

    @property
    def stage_names(self) -> list[str]:
        """What each stage asks for, in words ("place the 2 mL microtube on the microcentrifuge")."""
        return [step_name(stage.step, self.checked) for stage in self.stages]

    @property
    def file_stem(self) -> str:
        short = self.task_id.split("/", 1)[1].rsplit("-v", 1)[0]
        return re.sub(r"(?<!^)(?=[A-Z])", "_", short).lower()


def merge_instruments(instruments: list[InstrumentSpec]) -> list[InstrumentSpec]:
    """One state machine per instrument: the parts each stage needs (a motor to open it, a closure,
    a run) joined under its name."""
    merged: dict[str, InstrumentSpec] = {}
    for m in instruments:
        old = merged.get(m.name)
        if old is None:
            merged[m.name] = m
            continue
        parts = {k: getattr(old, k) or getattr(m, k) for k in ("closure", "motor", "run", "scale")}
        merged[m.name] = old.model_copy(update={**parts, "contents": [*old.contents, *m.contents]})
    return list(merged.values())


def held_after(program: list[StepSpec], held: str | None = None) -> str | None:
    """The object in the hand after ``program`` runs (starting with ``held`` in it)."""
    for step in program:
        if isinstance(step, PickSpec):
            held = step.object
        elif isinstance(step, RemoveFromSpec):
            held = step.object if step.to == "hold" else None
        elif isinstance(step, PlaceOnSpec | InsertIntoSpec):
            held = None
    return held


def continue_holding(stages: list[Stage]) -> list[Stage]:
    """Stages whose program starts by picking what the stage before left in the hand (a lid lifted
    off, then put back) start with the step after that pick: the hand holds it already."""
    out: list[Stage] = []
    held: str | None = None
    for stage in stages:
        program = stage.program
        if held is not None and program and isinstance(program[0], PickSpec) and program[0].object == held:
            stage = replace(stage, program=program[1:])
        held = held_after(stage.program, held)
        out.append(stage)
    return out


def compose(
    checked: CheckedPlan,
    *,
    namespace: str = "generated",
    task_id: str | None = None,
    remarks: tuple[str, ...] = (),
) -> ComposedTask:
    """Lay out and compose ``checked`` (see the module docstring).

    Raises:
        PlanError: no room within reach, an object that does not fit where it goes, parts in the
            wrong state for a step.
    """
    plan = checked.plan
    steps = plan.steps
    scene = SceneBuilder(checked)
    layout = scene.build()
    multi = len(steps) > 1
    builder = StageBuilder(scene, plan.thresholds, multi)
    stages = continue_holding([builder.build(step) for step in steps])
    comments: dict[str, str] = {}
    if multi:
        total = sum(s.criterion.timeout_s or 10.0 for s in stages)
        timeout = plan.thresholds.timeout_s or r(total, 1)
        of = [s.criterion.model_copy(update={"instruction": stage_instruction(s.step, checked)}) for s in stages]
        success: ev.EvaluatorSpec = ev.SequenceSpec(of=of, timeout_s=timeout)
        comments["success.of"] = "one stage per step, in order, each with its own instruction"
        for k, stage in enumerate(stages):
            comments.update({f"success.of.{k}.{path}": text for path, text in stage.comments.items()})
    else:
        success = stages[0].criterion
        comments.update({f"success.{path}": text for path, text in stages[0].comments.items()})
    program = [skill for stage in stages for skill in stage.program]
    releases = [m for stage in stages for m in stage.mechanisms]
    instruments = merge_instruments([m for stage in stages for m in stage.instruments])
    if len({m.joint for m in releases}) < len(releases) or any(
        s.action == "close" and any(m.joint.startswith(f"{s.object}/") for m in releases) for s in steps
    ):
        raise PlanError(
            "a release button holds its lid open once pressed; a task cannot press it and then close "
            "that lid, or press it twice"
        )
    targets = list(dict.fromkeys(t for stage in stages for t in stage.targets))
    objects = list(layout.placed.values())
    robot = checked.robot.name
    tid = task_id or derive_id(checked, namespace)
    name = ", then ".join(step_name(s, checked) for s in steps)
    tags = ["generated", *dict.fromkeys(s.action for s in steps)]
    if any(o.info.category == "instruments" for o in checked.objects.values()):
        tags.append("instrument")
    if multi:
        tags.append("multi-step")
    if robot != DEFAULT_ROBOT:
        tags.append(next(iter(robot_spec(robot).aliases), robot))
    notes = [
        (
            "scene.objects",
            "VERIFY the layout: computed by pipette new-task to be reachable and collision-free at "
            "reset; render it with pipette sim render.",
        ),
        (
            "success",
            "VERIFY the thresholds (derived from the assets' geometry, see the comments) against a "
            "scripted or teleoperated demonstration.",
        ),
    ]
    for remark in remarks:
        index = next((i for i, o in enumerate(objects) if remark.endswith(o.asset)), None)
        notes.append(
            (f"scene.objects.{index}.asset" if index is not None else "scene.objects", f"VERIFY the choice: {remark}.")
        )
    if robot != DEFAULT_ROBOT:
        notes.append(("cameras.wrist", f"VERIFY the wrist camera mount on the {robot}."))
    category = CATEGORY[steps[-1].action] if not multi else "other"
    return ComposedTask(
        task_id=tid,
        name=name[:1].upper() + name[1:],
        category=category,
        tags=tags,
        instruction=plan.instruction,
        robot=robot,
        initial_joints=[r(v, 4) for v in checked.robot.arm.home],
        objects=objects,
        joint_states=layout.joint_states,
        mechanisms=[*releases, *instruments],
        targets=targets,
        stages=stages,
        success=success,
        program=program,
        comments=comments,
        notes=notes,
        cameras=_cameras(objects, robot),
        checked=checked,
        starts={item: holder for item, (holder, _) in layout.start_site.items()},
    )


def _cameras(objects: list[PlacedObject], robot: str) -> dict[str, dict[str, Any]]:
    cx = r(float(np.mean([o.pos[0] for o in objects])), 2)
    cy = r(float(np.mean([o.pos[1] for o in objects])), 2)
    return {
        "top": {"pos": (r(cx + 0.5, 2), cy, 1.6), "look_at": (cx, cy, 0.6), "fovy_deg": 55},
        "main": {"pos": (r(cx + 0.75, 2), r(cy - 0.75, 2), 1.1), "look_at": (cx, cy, 0.65), "fovy_deg": 45},
        "wrist": {"mount": "end_effector", **robot_spec(robot).wrist_camera.model_dump()},
    }
