"""The offline backend's last stage: the steps read from a description -> a :class:`TaskPlanSpec`.

The parser (:mod:`.parser`) reads clauses into objects and raw steps. Here a pick followed by a
placement of the same object becomes one step, a step said twice is done once, every object gets an
asset (a holder and the item it takes are chosen together, so that the item fits) and a name unique
in the plan, and the plan is validated.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pipette_cli.authoring.clause import Mention
from pipette_cli.language.assets import Vocabulary
from pipette_cli.taskgen.plan import (
    INSTRUMENT_ACTIONS,
    PlanError,
    PlanObjectSpec,
    PlanStepSpec,
    PlanThresholdsSpec,
    Relation,
    TaskPlanSpec,
)
from pipette_cli.taskgen.resolve import Wanted, candidates, choose_pair, hole


@dataclass(eq=False)
class Obj:
    """An object of the plan being built."""

    mention: Mention
    wanted: Wanted
    asset: str | None = None
    name: str = ""


@dataclass
class RawStep:
    action: str
    object: Obj | None
    target: Obj | None = None
    source: Obj | None = None
    part: str | None = None
    relation: Relation | None = None


def assemble(
    vocab: Vocabulary,
    objects: list[Obj],
    steps: list[RawStep],
    robot: str | None,
    thresholds: dict[str, float],
    instruction: str,
) -> tuple[TaskPlanSpec, list[str]]:
    """The plan of ``steps`` over ``objects`` and the remarks on choices among equal assets.

    Raises:
        PlanError: the plan does not validate (with pydantic's reason).
    """
    steps = merged(steps)
    remarks = choose_assets(vocab, objects, steps)
    used = [o for o in objects if any(o in (s.object, s.target, s.source) for s in steps)]
    extra = [o for o in objects if o not in used]
    name_objects(used + extra)
    roles = _roles(steps)
    plan_objects = [
        PlanObjectSpec(name=o.name, asset=o.asset, role=roles.get(id(o), "distractor")) for o in used + extra
    ]
    try:
        plan = TaskPlanSpec(
            objects=plan_objects,
            steps=[_plan_step(s) for s in steps],
            robot=robot,
            instruction=instruction,
            thresholds=PlanThresholdsSpec(**thresholds),
        )
    except ValueError as exc:
        raise PlanError(f"could not make a plan: {exc}") from None
    return plan, remarks


def merged(steps: list[RawStep]) -> list[RawStep]:
    """``steps`` with a pick or removal and the placement of the same object as one step, and a step
    said twice in a row as one."""
    out: list[RawStep] = []
    for step in steps:
        last = out[-1] if out else None
        if (
            last is not None
            and last.object is step.object
            and last.action == "pick"
            and step.action in ("place", "position", "pick", "remove")
        ):
            step.source = step.source or last.source
            out[-1] = step  # "pick up the tube and put it on the balance" is one placement
            continue
        if (
            last is not None
            and last.object is step.object
            and last.action == "remove"
            and step.action in ("place", "position", "remove")
            and step.source in (None, last.source)
        ):
            step.source = step.source or last.source
            out[-1] = step  # "take the tube out of the rack and put it on the balance"
            continue
        if (
            last is not None
            and (last.action, last.object, last.part, last.target) == (step.action, step.object, step.part, step.target)
            and step.action in (*INSTRUMENT_ACTIONS, "position", "place")
        ):
            continue  # "hold it over the beaker and keep it there": said twice, done once
        out.append(step)
    return out


def choose_assets(vocab: Vocabulary, objects: list[Obj], steps: list[RawStep]) -> list[str]:
    """Give every object its asset; returns a remark for each choice among several that fit."""
    options = {id(o): candidates(vocab, o.wanted) for o in objects}
    for step in steps:
        item = step.object
        for holder in (step.target if step.action == "place" else None, step.source):
            if item is None or holder is None or holder.asset:
                continue
            if any(hole(vocab, h) is not None for h in options[id(holder)]):
                items = [item.asset] if item.asset else options[id(item)]
                i, h = choose_pair(vocab, items, options[id(holder)])
                item.asset, holder.asset = i, h
    remarks = []
    for o in objects:
        choice = options[id(o)]
        o.asset = o.asset or choice[0]
        kind = vocab.kinds[o.wanted.kind]
        if len(choice) > 1 and not o.wanted.sizes and o.asset != kind.default:
            remarks.append(f"'{o.mention.phrase}' could be {', '.join(choice[:4])}; chose {o.asset}")
    return remarks


def name_objects(objects: list[Obj]) -> None:
    """Name each object after its kind's last word (``tube``), its whole kind where that is taken by
    another kind, and a number after that."""
    taken: set[str] = set()
    for o in objects:
        kind = o.wanted.kind
        base = re.sub(r"[^a-z0-9]+", "_", kind.split()[-1]).strip("_") or "object"
        if base in taken and not any(p.name == base and p.wanted.kind == kind for p in objects if p.name):
            base = re.sub(r"[^a-z0-9]+", "_", kind).strip("_")
        name, n = base, 2
        while name in taken:
            name, n = f"{base}_{n}", n + 1
        o.name = name
        taken.add(name)


def _plan_step(step: RawStep) -> PlanStepSpec:
    if step.object is None:  # the parser gives every step its object or refuses the description
        raise PlanError(f"say what to {step.action}")
    return PlanStepSpec(
        action=step.action,
        object=step.object.name,
        target=step.target.name if step.target else None,
        relation=step.relation,
        source=step.source.name if step.source else None,
        part=step.part,
    )


def _roles(steps: list[RawStep]) -> dict[int, str]:
    roles: dict[int, str] = {}
    for s in steps:
        if s.action in INSTRUMENT_ACTIONS:
            roles.setdefault(id(s.object), "instrument")
            continue
        roles.setdefault(id(s.object), "item")
        if s.target is not None:
            roles.setdefault(id(s.target), "target" if s.action == "position" or s.relation else "destination")
        if s.source is not None:
            roles.setdefault(id(s.source), "source")
    return roles
