"""Run a task's scripted expert over many seeds without rendering and report its success rate."""

from __future__ import annotations

import re
import time
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from pipette_cli.demos.embodiment import on_robot
from pipette_cli.demos.experts.base import Expert, expert_failure, find_expert
from pipette_cli.errors import InfeasibleTask
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.world import World
from pipette_cli.specs.task import TaskSpec, stage_specs

EXPERT_FAILED = "expert_failed"
"""Failure reason of an episode whose expert gave up (a skill step could not do its job)."""
LIMIT = re.compile(r"\): ((?:reach|payload|gripper): .*)$")
"""An expert failure naming a limit of the robot that a skill found before moving
(``step N (...): reach: ...``): another robot may not have it."""
LIMIT_SEEDS = (0, 1, 2)
"""Seeds on which the expert must stop at a limit of the robot for the robot to be refused."""


@dataclass
class ExpertReport:
    """Outcome of an expert over ``episodes`` seeds."""

    task_id: str
    episodes: int = 0
    successes: int = 0
    failures: Counter[str] = field(default_factory=Counter)
    failed_seeds: list[int] = field(default_factory=list)
    expert_failures: dict[int, str] = field(default_factory=dict)
    """Seed -> the one-line reason the expert stopped (which step, why)."""
    mean_steps: float = 0.0
    seconds: float = 0.0
    episode_seconds: list[float] = field(default_factory=list)
    stage_count: int = 0
    """Stages of the task's ``sequence`` criterion (0 for single-stage tasks)."""
    stages: list[int] = field(default_factory=list)
    """Stages completed in each episode, in seed order."""

    @property
    def success_rate(self) -> float:
        return self.successes / self.episodes if self.episodes else 0.0

    @property
    def mean_progress(self) -> float:
        """Mean fraction of the stages completed (success rate for single-stage tasks)."""
        if not self.stage_count:
            return self.success_rate
        return float(np.mean(self.stages)) / self.stage_count if self.stages else 0.0

    @property
    def median_seconds(self) -> float:
        return float(np.median(self.episode_seconds)) if self.episode_seconds else 0.0


def step_of(failure: str) -> str:
    """``step 2 (place_on dish): ...`` -> ``place_on``."""
    match = re.match(r"step \d+ \((\w+)", failure)
    return match.group(1) if match else "unknown"


def run_expert_episode(
    world: World, seed: int, max_steps: int | None = None, expert: Expert | None = None
) -> tuple[Verdict, str | None]:
    """Reset ``world`` to ``seed`` and let the task's expert act until the evaluator decides or the
    expert gives up. Returns the verdict and, if the expert gave up, why."""
    world.reset(seed)
    expert = expert if expert is not None else find_expert(world.task)[1]
    expert.reset(world, np.random.default_rng([seed, 1]))
    verdict = world.verdict
    limit = max_steps or int(1e6)
    while not verdict.done and world.step_count < limit:
        verdict = world.step(expert.act(world))
        failure = expert_failure(expert)
        if failure is not None and not verdict.done:
            return Verdict(failed=True, reason=EXPERT_FAILED, metrics=verdict.metrics), failure
    return verdict, expert_failure(expert)


def check_expert(task: TaskSpec, episodes: int, seed: int = 0) -> ExpertReport:
    """Success statistics of the task's expert on seeds ``seed .. seed + episodes - 1``."""
    world = World(task)
    report = ExpertReport(task.id, stage_count=len(stage_specs(task)))
    start = time.perf_counter()
    steps = 0
    for k in range(episodes):
        began = time.perf_counter()
        verdict, failure = run_expert_episode(world, seed + k)
        report.episode_seconds.append(time.perf_counter() - began)
        report.episodes += 1
        steps += world.step_count
        report.stages.append(world.stage)
        if verdict.success:
            report.successes += 1
        else:
            report.failures[verdict.reason or "unknown"] += 1
            report.failed_seeds.append(seed + k)
            if failure is not None:
                report.expert_failures[seed + k] = failure
    report.seconds = time.perf_counter() - start
    report.mean_steps = steps / max(1, report.episodes)
    return report


def robot_limit(task: TaskSpec, seeds: tuple[int, ...] = LIMIT_SEEDS) -> str | None:
    """The limit of the task's robot that rules the task out ("reach: the push on ... starts 0.61 m
    above the agilex_piper's base ..."): the expert, run without rendering, stops naming one on
    every seed of ``seeds``; None as soon as a seed does not."""
    world = World(task)
    found: str | None = None
    for seed in seeds:
        _, failure = run_expert_episode(world, seed)
        limit = LIMIT.search(failure or "")
        if limit is None:
            return None
        found = found or limit.group(1)
    return found


def placed_on(task: TaskSpec, robot: str | None) -> TaskSpec:
    """``task`` on ``robot`` (:func:`~pipette_cli.demos.embodiment.on_robot`), checked up front where
    the robot is not the task's own: a robot whose expert stops at a limit of its own on every seed
    of :data:`LIMIT_SEEDS` is refused before any episode is recorded or evaluated.

    Raises:
        SimError: unknown robot.
        InfeasibleTask: the robot cannot do the task (payload, reach, gripper: the limit named).
    """
    placed = on_robot(task, robot)
    if placed.embodiment.robot == task.embodiment.robot:
        return placed
    limit = robot_limit(placed)
    if limit is not None:
        seeds = f"{LIMIT_SEEDS[0]}-{LIMIT_SEEDS[-1]}"
        raise InfeasibleTask(f"{task.id} on the {placed.embodiment.robot}: {limit} (its expert, seeds {seeds})")
    return placed
