"""``--check``: does a drafted task build, start unsolved, stay put, and can an expert solve it?

1. Build the :class:`~pipette_cli.sim.world.World` (compile, no interpenetration, reach).
2. For each episode seed: reset, then hold the robot still for the whole time limit. The
   evaluator must not succeed (a task solved by doing nothing is a broken task) and the free
   objects must stay where they were put (a tube rolling off the pan is a broken layout).
3. :func:`solve_check`: run the task's expert (its ``expert:`` skill program) for the seeds and
   count the successes; a failed episode is reported with the stage of the success criterion it
   did not get past and the expert step that stopped. The task passes when the expert succeeds on
   at least :data:`SOLVE_SHARE` of the seeds (4 of 5).
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from pipette_cli.demos.check import run_expert_episode
from pipette_cli.demos.experts.base import find_expert
from pipette_cli.errors import PipetteError, plural
from pipette_cli.sim.world import World
from pipette_cli.specs.task import TaskSpec

if TYPE_CHECKING:
    from pipette_cli.evaluators.base import Verdict

SOLVE_SHARE = 0.8
"""Share of seeds the expert must solve for ``--check`` to pass (4 of 5)."""
DEFAULT_EPISODES = 5
MAX_DRIFT_M = 0.05
"""Free objects may drift this much while the robot stands still (lying tubes and pipettes rock by a few cm in the registry too)."""


@dataclass
class SolveReport:
    """Outcome of running a scripted expert on a task."""

    status: str  # "solved" | "unsolved" | "not_checked"
    expert: str | None = None
    successes: int = 0
    episodes: int = 0
    reasons: list[str] = field(default_factory=list)
    """One line per failed seed: the stage not reached and the expert step that stopped."""
    classes: dict[str, list[int]] = field(default_factory=dict)
    """The failed seeds by :func:`failure_class`."""
    detail: str = ""

    @property
    def required(self) -> int:
        return math.ceil(SOLVE_SHARE * self.episodes)

    def summary(self) -> str:
        if self.status == "not_checked":
            return f"solvability not checked: {self.detail}"
        seeds: dict[str, list[str]] = {}
        for line in self.reasons:  # "seed 3: why" -> "seeds 1, 3: why"
            seed, _, why = line.partition(": ")
            seeds.setdefault(why, []).append(seed.removeprefix("seed "))
        failures = [f"seed{'s' if len(s) > 1 else ''} {', '.join(s)}: {why}" for why, s in seeds.items()]
        return (
            f"expert '{self.expert}' solved {self.successes}/{plural(self.episodes, 'episode')} (needs {self.required})"
            + (f"; {'; '.join(failures)}" if failures else "")
        )


@dataclass
class CheckReport:
    """Outcome of :func:`check_task`."""

    task_id: str
    problems: list[str] = field(default_factory=list)
    episodes: int = 0
    idle_steps: int = 0
    max_drift_m: float = 0.0
    solve: SolveReport = field(default_factory=lambda: SolveReport("not_checked", detail="not run"))
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.problems

    def as_dict(self) -> dict[str, Any]:
        return {
            "task": self.task_id,
            "ok": self.ok,
            "problems": self.problems,
            "episodes": self.episodes,
            "idle_steps": self.idle_steps,
            "max_drift_m": round(self.max_drift_m, 4),
            "solve": {
                "status": self.solve.status,
                "expert": self.solve.expert,
                "successes": self.solve.successes,
                "episodes": self.solve.episodes,
                "detail": self.solve.summary(),
                "failure_classes": self.solve.classes,
            },
            "seconds": round(self.seconds, 2),
        }


def failure_class(failure: str | None, reason: str | None) -> str:
    """A failed episode's class, the same for every object and place: the skill that stopped and why
    (``"pick: the grasp on X did not hold"``, ``"insert_into: no reachable way to hold X upright"``),
    or the criterion's unmet reason (``"evaluator: tilted"``)."""
    if not failure:
        return f"evaluator: {reason or 'not done'}"
    skill = re.match(r"step \d+ \((\w+)", failure)
    message = failure.split("): ", 1)[-1]
    message = message.rsplit(": ", 1)[-1] if re.search(r"\): ", message) else message
    message = re.sub(r"'[^']*'", "X", message)
    message = re.sub(r"\([^()]*\)", "", message)
    message = re.sub(r"\s+", " ", re.sub(r"-?\d+(\.\d+)?\s*(mm|m|deg|N|s|%)?", "", message)).strip(" ,;:")
    return f"{skill.group(1) if skill else 'expert'}: {message}"


def _idle_action(world: World) -> np.ndarray:
    gripper = 1.0 if world.task.embodiment.gripper == "open" else 0.0
    return np.append(np.asarray(world.task.embodiment.initial_joints, dtype=float), gripper)


def _episode_steps(task: TaskSpec, world: World) -> int:
    timeout = task.success.timeout_s or 10.0
    return int(np.ceil(min(timeout, 30.0) / world.control_dt)) + 1


def check_task(
    task: TaskSpec, episodes: int = DEFAULT_EPISODES, *, solve: bool = True, stage_names: list[str] | None = None
) -> CheckReport:
    """Build ``task`` and run the checks above; problems are listed, never raised.

    Args:
        task: The task to check.
        episodes: Seeds 0..episodes-1, for the idle rollout and for the expert.
        solve: Run the expert too.
        stage_names: What each stage of the success criterion is ("place the tube on the
            balance"), for the failure lines; else "stage k of n".
    """
    start = time.perf_counter()
    report = CheckReport(task.id, episodes=episodes)
    try:
        world = World(task)
    except PipetteError as exc:
        report.problems.append(f"the scene does not build: {exc}")
        report.seconds = time.perf_counter() - start
        return report
    free = [o.name for o in task.scene.objects if world.objects[o.name].free]
    for seed in range(episodes):
        world.reset(seed)
        action = _idle_action(world)
        verdict = world.step(action)
        if verdict.success:
            report.problems.append(f"seed {seed}: the evaluator succeeds right after reset")
            continue
        start_pos = {name: world.position(name) for name in free}
        steps = _episode_steps(task, world)
        for _ in range(steps):
            verdict = world.step(action)
            if verdict.success:
                report.problems.append(
                    f"seed {seed}: the evaluator succeeds while the robot does nothing "
                    f"(t = {world.step_count * world.control_dt:.1f} s); the task is trivial"
                )
                break
            if verdict.done:
                break
        report.idle_steps += world.step_count
        for name in free:
            drift = float(np.linalg.norm(world.position(name) - start_pos[name]))
            report.max_drift_m = max(report.max_drift_m, drift)
            if drift > MAX_DRIFT_M:
                report.problems.append(
                    f"seed {seed}: {name} moved {drift * 1000:.0f} mm by itself while the robot "
                    "stood still; it does not rest where the layout put it"
                )
    if solve and report.ok:
        report.solve = solve_check(task, episodes, stage_names)
    report.seconds = time.perf_counter() - start
    return report


def _stage_line(task_spec: TaskSpec, verdict: Verdict, stage_names: list[str] | None) -> str:
    """Which stage of the criterion an episode did not get past."""
    stages = len(getattr(task_spec.success, "of", None) or []) if task_spec.success.type == "sequence" else 1
    k = int(verdict.metrics.get("stage", 0)) if stages > 1 else 0
    k = min(k, stages - 1)
    name = stage_names[k] if stage_names and k < len(stage_names) else None
    where = f"stage {k + 1} of {stages}" + (f" ({name})" if name else "") if stages > 1 else (name or "the criterion")
    return f"{where} not met"


def solve_check(task_spec: TaskSpec, episodes: int, stage_names: list[str] | None = None) -> SolveReport:
    """Run the task's scripted expert (its skill program, or one read off its criterion) for
    ``episodes`` seeds; ``status`` is "solved" when at least :data:`SOLVE_SHARE` of them succeed.

    Returns ``status="not_checked"`` when the task has no program and none can be derived.
    """
    try:
        name, expert = find_expert(task_spec)
    except PipetteError as exc:
        return SolveReport("not_checked", detail=str(exc))
    world = World(task_spec)
    report = SolveReport("unsolved", expert=name, episodes=episodes)
    for seed in range(episodes):
        verdict, failure = run_expert_episode(world, seed, _episode_steps(task_spec, world) + 30, expert=expert)
        if verdict.success:
            report.successes += 1
        else:
            why = f"expert stopped at {failure}" if failure else f"evaluator: {verdict.reason or 'not done'}"
            report.classes.setdefault(failure_class(failure, verdict.reason), []).append(seed)
            report.reasons.append(f"seed {seed}: {_stage_line(task_spec, verdict, stage_names)}; {why}")
    if report.successes >= report.required:
        report.status = "solved"
    return report
