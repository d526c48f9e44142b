"""Run a task's scripted expert over many seeds without rendering and report its success rate."""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from pipette_cli.demos.experts.base import find_expert, make_expert
from pipette_cli.sim.world import World
from pipette_cli.specs.task import TaskSpec


@dataclass
class ExpertReport:
    """Outcome of an expert over ``episodes`` seeds."""

    task_id: str
    episodes: int = 0
    successes: int = 0
    failures: Counter[str] = field(default_factory=Counter)
    failed_seeds: list[int] = field(default_factory=list)
    mean_steps: float = 0.0
    seconds: float = 0.0

    @property
    def success_rate(self) -> float:
        return self.successes / self.episodes if self.episodes else 0.0


def run_expert_episode(world: World, task_id: str | None, seed: int, max_steps: int | None = None):
    """Reset ``world`` to ``seed`` and let the expert act until the evaluator decides.

    ``task_id`` names the expert; ``None`` picks the world's task's own or family expert
    (:func:`~pipette_cli.demos.experts.base.find_expert`).
    """
    world.reset(seed)
    expert = make_expert(task_id) if task_id is not None else find_expert(world.task)[1]
    expert.reset(world, np.random.default_rng(seed))
    verdict = world.verdict
    limit = max_steps or int(1e6)
    while not verdict.done and world.step_count < limit:
        verdict = world.step(expert.act(world))
    return verdict


def check_expert(task: TaskSpec, episodes: int, seed: int = 0) -> ExpertReport:
    """Success statistics of the task's expert on seeds ``seed .. seed + episodes - 1``."""
    world = World(task)
    report = ExpertReport(task.id)
    start = time.perf_counter()
    steps = 0
    for k in range(episodes):
        verdict = run_expert_episode(world, None, seed + k)
        report.episodes += 1
        steps += world.step_count
        if verdict.success:
            report.successes += 1
        else:
            report.failures[verdict.reason or "unknown"] += 1
            report.failed_seeds.append(seed + k)
    report.seconds = time.perf_counter() - start
    report.mean_steps = steps / max(1, report.episodes)
    return report
