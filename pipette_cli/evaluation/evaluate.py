"""Online evaluation of a policy in a task (paper A.4, A.6): 30 Hz control, 10 Hz queries.

ACT: joint targets are interpolated linearly between two queries,
``q_cmd = (1 - a) q_prev + a q_curr`` with ``a = min(m / d_pi, 1)``. SmolVLA / pi0: the returned
action chunk is executed step by step until the next query replaces it. The gripper is open when
``u >= 0.5`` (pi0: hysteresis, open at ``u >= 0.55`` from closed, stays open while ``u > 0.45``).
After 6 (pi0: 20) consecutive failed queries the robot holds ``[q_now, open]`` for the rest of
the episode. A server that is down (:class:`~pipette_cli.serving.client.PolicyUnreachable`) is
not a transient failure: the robot takes the same safe hold at once and :class:`ServerLost`
stops the run (the episode is not counted; a resumed run plays it again).

This module runs one episode; :mod:`pipette_cli.evaluation.runner` runs many (suites, resume,
workers) and :mod:`pipette_cli.evaluation.results` writes and summarises their logs.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from pipette_cli.errors import PipetteError
from pipette_cli.evaluation.conditions import episode_conditions
from pipette_cli.evaluation.settings import DecodeConfig
from pipette_cli.serving.client import PolicyUnreachable
from pipette_cli.serving.protocol import DEFAULT_DEVICE
from pipette_cli.serving.server import LeRobotRunner
from pipette_cli.sim.env import Observation, PipetteEnv
from pipette_cli.specs.perturbations import PerturbationSpec


class ActionSource(Protocol):
    """A policy: an in-process runner or a :class:`~pipette_cli.serving.client.PolicyClient`."""

    def act(self, observation: dict[str, np.ndarray], *, task: str, reset: bool, chunk: bool) -> np.ndarray: ...


class InProcessSource:
    """A LeRobot policy loaded in this process (no server)."""

    def __init__(self, path: Path, device: str = DEFAULT_DEVICE) -> None:
        self.runner = LeRobotRunner(Path(path), device=device)

    def act(self, observation: dict[str, np.ndarray], *, task: str, reset: bool, chunk: bool) -> np.ndarray:
        if reset:
            self.runner.reset()
        return self.runner.act(observation, task, chunk=chunk)


def policy_observation(obs: Observation, float_images: bool) -> dict[str, np.ndarray]:
    """LeRobot keys, CHW images (uint8, or float32 in [0, 1]) and the state."""
    out: dict[str, np.ndarray] = {}
    for name, image in obs.images.items():
        chw = np.ascontiguousarray(image.transpose(2, 0, 1))
        out[f"observation.images.{name}"] = (chw.astype(np.float32) / 255.0) if float_images else chw
    out["observation.state"] = np.asarray(obs.state, dtype=np.float32)
    return out


@dataclass
class EpisodeLog:
    """What paper A.4 asks to be written per episode, with the instruction given and, for
    staged tasks (a ``sequence`` criterion), the share of stages completed."""

    task: str
    episode: int
    seed: int
    instruction: str
    success: bool
    failure_reason: str | None
    runtime_s: float
    sim_time_s: float
    control_steps: int
    control_hz: float
    policy_queries: int
    policy_hz: float
    failed_queries: int
    safe_hold: bool
    policy_type: str
    gripper_thresholds: dict[str, float]
    metrics: dict[str, float] = field(default_factory=dict)
    progress: float | None = None
    """``stage / stages`` of a staged task at the episode's end (1.0 on success); None otherwise."""
    conditions: dict[str, Any] = field(default_factory=dict)
    """What a shifted suite's perturbations drew for this episode (empty on a nominal suite)."""
    environment: dict[str, Any] = field(default_factory=dict)
    """Where it ran: MuJoCo, renderer, GL backend, git commit (:func:`~pipette_cli.evaluation.results.environment_record`)."""


class ServerLost(PipetteError):
    """The policy server became unreachable during an episode; the safe hold was applied.

    The CLI exits with ``exit_code`` 3, so that a script tells a run that stopped with a
    partial summary (rerun to resume) from a finished one (0) and from a refused one (1).

    Attributes:
        record: task, episode, seed, control step, the hold action and the time it was applied.
    """

    exit_code = 3

    def __init__(self, message: str, record: dict[str, Any]) -> None:
        self.record = record
        super().__init__(message)


class EpisodeInterrupted(Exception):
    """Ctrl-C during an episode: it is dropped, and a resumed run plays it again."""


def stage_progress(metrics: dict[str, float]) -> float | None:
    """``stage / stages`` from a top-level ``sequence`` criterion's metrics; None for other tasks."""
    stage, stages = metrics.get("stage"), metrics.get("stages")
    if stage is None or not stages:
        return None
    return float(stage) / float(stages)


class Gripper:
    """Binary gripper decision with optional hysteresis."""

    def __init__(self, config: DecodeConfig) -> None:
        self.config = config
        self.open = True

    def __call__(self, value: float) -> float:
        c = self.config
        if c.open_threshold == c.stay_open_threshold:  # plain threshold: open when u >= 0.5
            self.open = value >= c.open_threshold
        elif self.open:  # hysteresis: stay open while u > 0.45 ...
            self.open = value > c.stay_open_threshold
        else:  # ... and open again only at u >= 0.55
            self.open = value >= c.open_threshold
        return 1.0 if self.open else 0.0


def run_episode(
    env: PipetteEnv,
    source: ActionSource,
    config: DecodeConfig,
    *,
    episode: int,
    seed: int,
    instruction: str | None = None,
    stop: Callable[[], bool] | None = None,
    conditions: Sequence[PerturbationSpec] = (),
) -> EpisodeLog:
    """One closed-loop episode; ends when the task's evaluator decides.

    Args:
        env: The task's environment (reset here with ``seed``).
        source: The policy.
        config: How its answers are decoded.
        episode: The episode's index (for the log).
        seed: The episode's seed.
        instruction: What the policy is told (default: the task's instruction).
        stop: Polled every control step; when true the episode is abandoned.
        conditions: A shifted suite's perturbations, drawn from ``seed`` and applied for the
            episode (:mod:`~pipette_cli.evaluation.conditions`); recorded in the log.

    Raises:
        ServerLost: the policy server became unreachable; the safe hold was applied first.
        EpisodeInterrupted: ``stop`` turned true.
    """
    task = env.task
    instruction = instruction or task.instruction
    with episode_conditions(env, seed, conditions) as (env, obs, drawn):  # the episode's own scene
        world = env.world
        d_pi = max(1, round(task.timing.control_hz / task.timing.vision_hz))
        gripper = Gripper(config)
        q_prev = q_curr = world.arm_qpos()
        raw_gripper = 1.0
        chunk: np.ndarray | None = None
        chunk_i = steps_since = 0
        queries = failures = consecutive = 0
        hold: np.ndarray | None = None
        verdict = world.verdict
        wall0 = time.perf_counter()
        while not verdict.done:
            if stop is not None and stop():
                raise EpisodeInterrupted(f"{task.id} episode {episode} interrupted")
            k = world.step_count
            if hold is None and k % d_pi == 0:
                try:
                    # a protocol's stage instruction where it has one, else this episode's (suite variants)
                    said = obs.instruction if obs.instruction != task.instruction else instruction
                    answer = source.act(
                        policy_observation(obs, config.float_images), task=said, reset=(k == 0), chunk=config.chunked
                    )
                    queries += 1
                    consecutive = 0
                    if config.chunked:
                        chunk, chunk_i = np.atleast_2d(answer), 0
                    else:
                        q_prev, q_curr, raw_gripper, steps_since = (
                            _commanded(q_prev, q_curr, steps_since, d_pi),
                            answer[:-1],
                            float(answer[-1]),
                            0,
                        )
                except PolicyUnreachable as exc:
                    hold = np.append(world.arm_qpos(), 1.0)  # paper A.4: [q_now, open], then stop the run
                    env.step(hold)
                    raise ServerLost(
                        str(exc),
                        {
                            "task": task.id,
                            "episode": episode,
                            "seed": seed,
                            "step": k,
                            "hold": hold.round(6).tolist(),
                            "held_at": time.time(),
                            "message": str(exc),
                        },
                    ) from None
                except PipetteError:
                    failures += 1
                    consecutive += 1
                    if consecutive >= config.max_consecutive_failures:
                        hold = np.append(world.arm_qpos(), 1.0)  # paper A.4: [q_now, open]
            if hold is not None:
                action = hold
            elif config.chunked and chunk is not None:
                row = chunk[min(chunk_i, len(chunk) - 1)]
                chunk_i += 1
                action = np.append(row[:-1], gripper(float(row[-1])))
            else:
                steps_since += 1
                target = _commanded(q_prev, q_curr, steps_since, d_pi)
                action = np.append(target, gripper(raw_gripper))
            obs, verdict = env.step(action)
        sim_time = world.time
        steps = world.step_count
        metrics = {k: float(v) for k, v in verdict.metrics.items()}
        return EpisodeLog(
            task=task.id,
            episode=episode,
            seed=seed,
            instruction=instruction,
            success=verdict.success,
            failure_reason=None
            if verdict.success
            else ("safe_hold" if hold is not None and not verdict.reason else verdict.reason),
            runtime_s=time.perf_counter() - wall0,
            sim_time_s=sim_time,
            control_steps=steps,
            control_hz=steps / sim_time if sim_time else 0.0,
            policy_queries=queries,
            policy_hz=queries / sim_time if sim_time else 0.0,
            failed_queries=failures,
            safe_hold=hold is not None,
            policy_type=config.policy_type,
            gripper_thresholds={"open": config.open_threshold, "stay_open": config.stay_open_threshold},
            metrics=metrics,
            progress=stage_progress(metrics),
            conditions=drawn,
        )


def _commanded(q_prev: np.ndarray, q_curr: np.ndarray, m: int, d_pi: int) -> np.ndarray:
    """Paper A.6: ``(1 - a) q_prev + a q_curr``, ``a = min(m / d_pi, 1)``, with ``m`` counting the
    control steps under the current goal including this one, so the goal is reached by the next query."""
    alpha = min(m / d_pi, 1.0)
    return (1.0 - alpha) * np.asarray(q_prev) + alpha * np.asarray(q_curr)
