"""The cheap physical checks of a task file (``pipette tasks validate``): build its scene and reset it.

What a task needs before any episode runs, checked in a fraction of a second per task without
stepping the physics: the scene compiles; at reset (seeds 0-19: the randomised layouts too) no two
of its objects, the bench and the robot interpenetrate; every object has collision geometry within
the robot's reach from its base (:class:`~pipette_cli.sim.world.World`'s build checks, which look
at the task's targets only); and every point its skill program works at lies between the robot's
minimum reach and its reach (:func:`~pipette_cli.demos.embodiment.reach_problems`, over the work
points that :func:`~pipette_cli.demos.embodiment.measure_workspace` reads). Problems come back as
field paths, for the caller to name ``file:line``.
"""

from __future__ import annotations

import logging
import re

from pipette_cli.demos.embodiment import measure_workspace, reach_problems
from pipette_cli.errors import EvaluatorError, PipetteError, SimError
from pipette_cli.sim.world import World
from pipette_cli.specs.task import TaskSpec
from pipette_cli.specs.yaml_io import Loc

log = logging.getLogger(__name__)


def scene_problems(task: TaskSpec) -> list[tuple[Loc, str]]:
    """``(field path, message)`` for every problem above; ``[]`` for a task that passes."""
    try:
        world = World(task, meshes="decimated", check=False)
        world.reset(seed=0)  # the evaluator looks up the parts it reads
        names = [obj.name for obj in task.scene.objects]
        problems = world.initial_state_problems(names)
    except EvaluatorError as exc:  # a task pack's criterion type without its runtime
        return [(("success", "type"), str(exc))]
    except SimError as exc:
        return [_located(task, str(exc))]
    reported = {loc for loc, _ in world.out_of_reach(names)}
    index = {obj.name: i for i, obj in enumerate(task.scene.objects)}
    try:
        space = measure_workspace(task)
    except PipetteError as exc:  # no program to read work points from (a teleoperation-only task)
        log.debug("%s: work points not checked: %s", task.id, exc)
        return problems
    for ref, message in reach_problems(task, world.robot, space):
        name = re.split(r"[/ ]", ref, maxsplit=1)[0]  # "incubator/shelf_0_center (entry)" -> "incubator"
        loc: Loc = ("scene", "objects", index[name], "pose") if name in index else ("embodiment", "base")
        if loc not in reported:  # an object out of reach is said once
            problems.append((loc, message))
    return problems


def _located(task: TaskSpec, message: str) -> tuple[Loc, str]:
    """A build error's field path and message (``"<id>: cameras.top.mount: no body ..."``)."""
    found = re.match(rf"{re.escape(task.id)}: ([\w.]+): (.*)$", message, re.DOTALL)
    if found is None:
        return (), message.removeprefix(f"{task.id}: ")
    loc = tuple(int(p) if p.isdigit() else p for p in found.group(1).split("."))
    return loc, found.group(2)
