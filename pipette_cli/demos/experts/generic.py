"""Family experts for tasks written by ``pipette new-task``: they read the plan off the task's
own success criterion and the assets' semantics, not off a task name.

``pick`` lifts the evaluator's object; ``place`` carries it to the evaluator's region (disc
centre or box middle); ``close_lid`` sweeps a hinged lid shut; ``press_button`` presses the
button of the scene's ``button_release`` mechanism. The benchmark tasks keep their own tuned
experts (:mod:`.plans`).
"""

from __future__ import annotations

import numpy as np

from pipette_cli.demos.experts.base import register_expert
from pipette_cli.demos.experts.motion import Segment, yaw_down
from pipette_cli.demos.experts.plans import (
    CLOSED,
    OPEN,
    UP,
    PlanExpert,
    close_lid_by_arc,
    open_centrifuge_lid,
    pick,
    seg,
)
from pipette_cli.errors import PipetteError
from pipette_cli.sim.world import World

SIDE_GRASP = yaw_down(np.pi / 2)


def _criterion(world: World, *types: str):
    spec = world.task.success
    if spec.type not in types:
        raise PipetteError(f"{world.task.id}: a {'/'.join(types)} criterion is needed, not {spec.type!r}")
    return spec


def grasp_point(world: World, obj: str) -> np.ndarray:
    """The object's ``grasp`` site if it has one, else 60 % up its height, but low enough for the
    hand's underside (about 4 cm above the fingertips) to clear its top."""
    try:
        return world.position(f"{obj}/grasp")
    except PipetteError:
        pass
    entry = world.objects[obj]
    from pipette_cli.assets.library import load_asset_library

    height = float(load_asset_library().get(entry.asset).semantics().get("dimensions", [0, 0, 0.08])[2])
    return world.position(obj) + max(0.01, min(0.6 * height, height - 0.03)) * UP


def pick_plan(world: World, rng: np.random.Generator) -> list[Segment]:
    spec = _criterion(world, "lift_and_hold")
    grasp = grasp_point(world, spec.object)
    lift = max(0.08, spec.min_height_gain + 0.05)
    return [*pick(world, grasp, SIDE_GRASP), seg(grasp + lift * UP, SIDE_GRASP, CLOSED, 0.9, world),
            seg(grasp + lift * UP, SIDE_GRASP, CLOSED, max(1.0, spec.hold_s + 0.5), world)]


def region_target(world: World, spec) -> np.ndarray:
    """Where the object's origin should end: the disc's centre site, or the middle of the box,
    standing on the lower height bound."""
    if spec.within is not None:
        return world.position(spec.within.center)
    here = world.position(spec.object)
    mid = [(b.min + b.max) / 2 if b and b.min is not None and b.max is not None else
           (b.min + 0.03 if b and b.min is not None else b.max - 0.03 if b else h)
           for b, h in ((spec.x, here[0]), (spec.y, here[1]))]
    z = spec.z.min if spec.z is not None and spec.z.min is not None else here[2]
    return np.array([mid[0], mid[1], z])


def place_plan(world: World, rng: np.random.Generator) -> list[Segment]:
    spec = _criterion(world, "region_hold", "stable_placement")
    grasp = grasp_point(world, spec.object)
    height = grasp[2] - world.position(spec.object)[2]
    target = region_target(world, spec)
    drop = target + (height - 0.002) * UP
    carry = 0.16
    return [
        *pick(world, grasp, SIDE_GRASP),
        seg(grasp + carry * UP, SIDE_GRASP, CLOSED, 0.7, world),
        seg(drop + carry * UP, SIDE_GRASP, CLOSED, 1.2, world),
        seg(drop, SIDE_GRASP, CLOSED, 0.8, world),
        seg(drop, SIDE_GRASP, OPEN, 0.4, world),
        seg(drop + 0.12 * UP, SIDE_GRASP, OPEN, 0.7, world),
        seg(drop + 0.12 * UP, SIDE_GRASP, OPEN, max(1.5, spec.hold_s + 1.0), world),
    ]


def close_lid_plan(world: World, rng: np.random.Generator) -> list[Segment]:
    spec = _criterion(world, "joint_threshold")
    obj = spec.joint.split("/")[0]
    return close_lid_by_arc(world, spec.joint, f"{obj}/lid_handle", reach=0.85)


def press_button_plan(world: World, rng: np.random.Generator) -> list[Segment]:
    spec = _criterion(world, "mechanism_triggered")
    mechanism = next(m for m in world.task.scene.mechanisms if m.name == spec.mechanism)
    obj = mechanism.button.split("/")[0]
    renamed = {"centrifuge": obj}  # the benchmark plan names its object "centrifuge"

    class _View:
        def __init__(self, world: World) -> None:
            self._world = world

        def __getattr__(self, name):
            return getattr(self._world, name)

        def position(self, ref: str) -> np.ndarray:
            head, _, part = ref.partition("/")
            return self._world.position(f"{renamed.get(head, head)}/{part}" if part else renamed.get(head, head))

    return open_centrifuge_lid(_View(world), rng)  # type: ignore[arg-type]


for _name, _plan in (("pick", pick_plan), ("place", place_plan), ("insert", place_plan), ("transfer", place_plan),
                     ("close_lid", close_lid_plan), ("lid", close_lid_plan), ("press_button", press_button_plan)):
    register_expert(_name)(lambda plan=_plan: PlanExpert(plan))
