"""One validator for every backend's plan: assets exist, each step can be done with those objects
by this robot, and the roles agree with the steps.

A plan from an LLM may name an asset by its words ("15 mL falcon tube"); the caller resolves them
(``resolve``: :func:`pipette_cli.authoring.workflow.resolve_asset` reads them as the offline parser
does), so no words are read here. Every problem is one sentence saying what to change,
so an LLM backend can send it back for a corrected answer. What no plan can fix (a plate wider
than the gripper opens) is said the same way.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

from pipette_cli.language.assets import AssetInfo, Vocabulary
from pipette_cli.skills.grip import fits_gripper, held_width
from pipette_cli.specs.robot import DEFAULT_ROBOT, RobotSpec, robot_spec
from pipette_cli.taskgen.measure import AssetGeometry, measure_asset, r
from pipette_cli.taskgen.plan import INSTRUMENT_ACTIONS, PlanError, PlanObjectSpec, PlanStepSpec, TaskPlanSpec

HINGED_PARTS = {"lid": ("lid_hinge",), "door": ("door_hinge",), "drawer": ("drawer_slide",), "sash": ("sash_slide",)}


@dataclass(frozen=True)
class CheckedObject:
    spec: PlanObjectSpec
    asset: str
    info: AssetInfo

    @property
    def name(self) -> str:
        return self.spec.name


@dataclass(frozen=True)
class CheckedPlan:
    """A plan whose assets are library ids and whose steps can be done."""

    plan: TaskPlanSpec
    objects: dict[str, CheckedObject]
    robot: RobotSpec

    @property
    def steps(self) -> list[PlanStepSpec]:
        return list(self.plan.steps)

    def asset(self, name: str) -> str:
        return self.objects[name].asset


def grip_width(geom: AssetGeometry, robot: RobotSpec) -> float | None:
    """Metres across the object where the skills' grasp would take it
    (:func:`pipette_cli.skills.grip.held_width`); None for a flat round object."""
    lying = geom.semantics.get("upright", True) is False or any(abs(a) > 45.0 for a in geom.rest_euler_deg[:2])
    grasp_z = geom.origin_height + float(geom.sites["grasp"][2]) if "grasp" in geom.sites else None
    return held_width(
        geom.boxes, geom.low, geom.high, finger_depth=robot.gripper.finger_depth, grasp_z=grasp_z, lying=lying
    )


def grip_problem(geom: AssetGeometry, robot: RobotSpec, name: str) -> str | None:
    """Why ``robot``'s gripper cannot hold the object, or None."""
    width = grip_width(geom, robot)
    opening = robot.gripper.max_opening
    if width is None or fits_gripper(width, opening):
        return None
    return (
        f"impossible request: the {name} is {width * 1000:.0f} mm across where it would be held; the "
        f"{robot.name}'s gripper opens {opening * 1000:.0f} mm, so it cannot hold it"
    )


def _check_step(
    i: int, step: PlanStepSpec, objects: dict[str, CheckedObject], robot: RobotSpec
) -> tuple[list[str], list[str]]:
    """The step's problems, and separately those that are limits of ``robot`` (opening, payload)."""
    where = f"steps.{i} ({step.action} {step.object})"
    obj = objects[step.object]
    info = obj.info
    human = info.human_name()
    problems: list[str] = []
    limits: list[str] = []
    if step.action in ("pick", "place", "remove", "position"):
        if not info.graspable:
            problems.append(
                f"{where}: impossible request: the {human} is fixed to the bench ({info.category}); the robot "
                f"cannot move it"
            )
            return problems, limits
        grip = grip_problem(measure_asset(obj.asset), robot, human)
        if grip:
            limits.append(f"{where}: {grip}")
        mass = float(info.semantics.get("mass", 0.0))
        if mass > robot.payload_kg:
            limits.append(
                f"{where}: the {human} weighs {mass:.1f} kg, over the {robot.name}'s {robot.payload_kg} kg payload"
            )
    if step.action in ("place", "position") and step.target is None:
        problems.append(f"{where}: say where it goes (target)")
    if step.action == "remove" and step.source is None and step.target is None:
        problems.append(f"{where}: say where it is taken from (source)")
    if step.target is not None and step.target == step.object:
        problems.append(f"{where}: contradictory request: the {human} cannot go into or onto itself")
    if step.action in ("open", "close"):
        if info.graspable and not info.static:
            problems.append(f"{where}: impossible request: the {human} is a loose object with nothing to {step.action}")
        elif not _openable(obj.asset, step.part):
            part = step.part or "lid, door or drawer"
            problems.append(f"{where}: impossible request: the {human} has no {part} to {step.action}")
    if step.action == "press" and "button" not in info.semantics.get("sites", []):
        problems.append(f"{where}: impossible request: the {human} has no button to press")
    if step.action == "run" and "start_button" not in info.semantics.get("sites", []):
        problems.append(
            f"{where}: the {human} has no start button: running instruments (heating, shaking, timed "
            "programs, knobs) is not simulated beyond a start button's run"
        )
    if step.action == "tare" and "tare_button" not in info.semantics.get("sites", []):
        problems.append(f"{where}: impossible request: the {human} has no tare button (only a balance is tared)")
    if step.relation is not None and step.action != "place":
        problems.append(f"{where}: a relation ({step.relation}) only says where a placement goes")
    return problems, limits


def _openable(asset: str, part: str | None) -> bool:
    geom = measure_asset(asset)
    joints = set(geom.joints)
    if part in HINGED_PARTS:
        return bool(joints & set(HINGED_PARTS[part])) or (part == "lid" and separate_lid(geom) is not None)
    movable = [j for j in joints if not j.endswith("knob_joint")]
    return bool(movable) or separate_lid(geom) is not None


def separate_lid(geom: AssetGeometry) -> str | None:
    """The asset id of a lift-off lid the asset's description names ("separate asset water_bath_lid")."""
    m = re.search(r"separate asset (\w+)", str(geom.semantics.get("description", "")))
    return m.group(1) if m else None


LID_CLEAR = 0.04
"""Metres beyond its own depth that a lift-off lid is drawn toward the robot (clear of the rim)."""


def lid_depth(lid: AssetGeometry) -> float:
    """A lift-off lid's depth to the centimetre: how far paper A.8's criterion asks it drawn toward
    the robot."""
    return r(2 * lid.half_xy[0], 2)


def lid_travel(lid: AssetGeometry) -> float:
    """How far a lift-off lid is drawn toward the robot once lifted: its depth and :data:`LID_CLEAR` more."""
    return lid_depth(lid) + LID_CLEAR


def lid_points(geom: AssetGeometry, opening: bool) -> list[tuple[float, float]]:
    """Where the hand works at an instrument's lift-off lid (its asset's ``lid_seat``): the seat and,
    opening it, where the hand ends with the lid drawn off toward the robot (:func:`lid_travel`)."""
    if "lid_seat" not in geom.sites:
        return []
    seat, lid = geom.sites["lid_seat"], separate_lid(geom)
    end = [(seat[0] - lid_travel(measure_asset(lid)), seat[1])] if opening and lid else []
    return [(seat[0], seat[1]), *end]


def lid_beside(geom: AssetGeometry, lid: AssetGeometry, gap: float) -> tuple[float, float]:
    """Where a lift-off lid set down beside its instrument lies, from the instrument's origin: on
    the robot's right (-y), ``gap`` from it, their centres level in x."""
    x = 0.5 * float(geom.low[0] + geom.high[0]) - 0.5 * float(lid.low[0] + lid.high[0])
    y = float(geom.low[1]) - gap - float(lid.high[1])
    return r(x), r(y)


def _asset_id(words: str, vocab: Vocabulary, resolve: Callable[[str], str] | None) -> str:
    if words in vocab.assets:
        return words
    if resolve is not None:
        return resolve(words)
    nearest = vocab.closest(words)
    raise PlanError(f"unknown asset id '{words}'; nearest: {', '.join(nearest) or 'see `pipette assets list`'}")


def _roles(plan: TaskPlanSpec) -> dict[str, str]:
    roles: dict[str, str] = {}
    for s in plan.steps:
        if s.action in INSTRUMENT_ACTIONS:
            roles.setdefault(s.object, "instrument")
            continue
        roles.setdefault(s.object, "item")
        if s.target:
            roles.setdefault(s.target, "target" if s.action == "position" or s.relation else "destination")
        if s.source:
            roles.setdefault(s.source, "source")
    return roles


def validate_plan(plan: TaskPlanSpec, vocab: Vocabulary, resolve: Callable[[str], str] | None = None) -> CheckedPlan:
    """Check ``plan`` against the asset library and the robot; ``resolve`` turns an object's
    ``asset`` that is no library id into one (without it, only ids are accepted).

    Raises:
        PlanError: every problem found, each saying what to change.
    """
    robot = robot_spec(plan.robot or DEFAULT_ROBOT)
    problems: list[str] = []
    objects: dict[str, CheckedObject] = {}
    roles = _roles(plan)
    fixed: list[PlanObjectSpec] = []
    for i, obj in enumerate(plan.objects):
        try:
            asset = _asset_id(obj.asset, vocab, resolve)
        except PlanError as exc:
            problems.append(f"objects.{i}.asset: {exc}")
            continue
        spec = obj.model_copy(update={"asset": asset, "role": roles.get(obj.name, "distractor")})
        fixed.append(spec)
        objects[obj.name] = CheckedObject(spec, asset, vocab.assets[asset])
    if problems:
        raise PlanError(problems)
    limits: list[str] = []
    for i, step in enumerate(plan.steps):
        step_problems, step_limits = _check_step(i, step, objects, robot)
        problems += step_problems
        limits += step_limits
    if problems or limits:
        raise PlanError([*problems, *limits], robot_limit=not problems)
    return CheckedPlan(plan.model_copy(update={"objects": fixed}), objects, robot)
