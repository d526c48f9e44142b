"""Record demonstrations into a dataset file: the episode loop, resume, worker processes, Ctrl-C.

The episode loop (paper A.3): ``obs = env.reset(seed)``; then per control step
``action = policy.act(world)``, record ``(obs, action, simulator state before the step)``,
``obs, verdict = env.step(action)``, until the evaluator decides (success or failure, its
timeout included) or a step cap. Episode ``i`` of a file uses seed ``S + i``; a rerun
resumes at the next index and seed (seeds already in the file are skipped, so a deleted
episode is not recorded again). Finished episodes become parts that :func:`~.store.pack`
moves into the file atomically at the end of the run, on Ctrl-C, and on error.

With ``workers > 1`` a spawn-context process pool runs episodes (each worker builds its own
env and GL context); results are committed in episode order, so the file does not depend on
the number of workers.
"""

from __future__ import annotations

import json
import logging
import math
import pickle
import signal
import threading
import time
from collections.abc import Callable, Generator, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pipette_cli.demos.check import EXPERT_FAILED
from pipette_cli.demos.experts.base import Expert, expert_failure, find_expert
from pipette_cli.demos.pool import ordered_pool
from pipette_cli.demos.provenance import mixing_problem, model_sha256, provenance
from pipette_cli.demos.recorder import DatasetInfo, EpisodeSummary, EpisodeWriter, commit_tmp, sim_state
from pipette_cli.demos.store import DatasetStatus, clean, pack, part_path, scan, writing
from pipette_cli.errors import DatasetError, PipetteError
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.env import PipetteEnv
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)

DEFAULT_LIMIT_S = 60.0
"""Episode length cap for tasks whose evaluator has no timeout."""


def step_cap(task: TaskSpec) -> int:
    """Default control-step cap: the evaluator's timeout plus one second of grace."""
    limit = task.success.timeout_s or DEFAULT_LIMIT_S
    return math.ceil(limit * task.timing.control_hz) + task.timing.control_hz


def episode_rng(seed: int) -> np.random.Generator:
    """The generator handed to ``Expert.reset`` (independent of the world's own ``default_rng(seed)``)."""
    return np.random.default_rng([seed, 1])


def plan_seeds(used: set[int], start: int, count: int) -> list[int]:
    """``count`` seeds from ``start`` upward, skipping seeds already in the file."""
    seeds: list[int] = []
    seed = start
    while len(seeds) < count:
        if seed not in used:
            seeds.append(seed)
        seed += 1
    return seeds


def record_episode(
    env: PipetteEnv,
    policy: Expert,
    writer: EpisodeWriter,
    *,
    max_steps: int,
    stop: Callable[[], bool] = lambda: False,
) -> EpisodeSummary | None:
    """Run one episode from ``writer.seed`` into ``writer``; ``None`` (and nothing kept) if ``stop()`` turns true."""
    obs = env.reset(writer.seed)
    policy.reset(env.world, episode_rng(writer.seed))
    verdict = Verdict()
    for _ in range(max_steps):
        if stop():
            writer.abort()
            return None
        action = np.asarray(policy.act(env.world), dtype=np.float64)
        writer.add(obs, action, sim_state(env.world.model, env.world.data))
        obs, verdict = env.step(action)
        if verdict.done:
            break
        failure = expert_failure(policy)
        if failure is not None:  # the expert gave up: record why, do not wait for the timeout
            log.info("episode %d: %s", writer.seed, failure)
            verdict = Verdict(failed=True, reason=f"{EXPERT_FAILED}: {failure}", metrics=verdict.metrics)
            break
    return writer.close(verdict, env.world.state(), sim_state(env.world.model, env.world.data))


@dataclass(frozen=True)
class Job:
    index: int
    seed: int
    part: Path


class EpisodeRunner:
    """One env and one expert, recording jobs into closed (not yet committed) part files."""

    def __init__(
        self,
        task: TaskSpec,
        *,
        image_size: int | None,
        render_profile: str,
        expert_factory: Callable[[], Expert] | None,
        attrs: dict[str, Any],
        max_steps: int,
        source: str = "scripted",
    ) -> None:
        self.expert = expert_factory() if expert_factory is not None else find_expert(task)[1]
        self.env = PipetteEnv(task, image_size=image_size, render_profile=render_profile)  # type: ignore[arg-type]
        self.info = DatasetInfo.from_env(self.env)
        expert_name = f"{type(self.expert).__module__}.{type(self.expert).__qualname__}"
        self.attrs = {**attrs, "model_sha256": model_sha256(self.env.world.model), "expert": expert_name}
        steps = getattr(self.expert, "steps", None)
        if steps:  # the skill program the demonstrations follow, for provenance
            self.attrs["expert_program"] = json.dumps(
                [
                    step.model_dump(mode="json", by_alias=True, exclude_defaults=True) | {"skill": step.skill}
                    for step in steps
                ]
            )
        self.max_steps = max_steps
        self.source = source

    def run(self, job: Job, stop: Callable[[], bool] = lambda: False) -> tuple[Path, EpisodeSummary] | None:
        writer = EpisodeWriter(
            job.part, self.info, index=job.index, seed=job.seed, source=self.source, attrs=self.attrs
        )
        with writer:
            summary = record_episode(self.env, self.expert, writer, max_steps=self.max_steps, stop=stop)
        return None if summary is None else (writer.tmp, summary)

    def close(self) -> None:
        self.env.close()


_RUNNER: EpisodeRunner | None = None
_INIT_ERROR: BaseException | None = None


def _init_worker(kwargs: dict[str, Any]) -> None:
    global _RUNNER, _INIT_ERROR
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    try:
        _RUNNER = EpisodeRunner(**kwargs)
    except Exception as exc:  # a failing initializer would make the pool respawn workers forever
        _INIT_ERROR = exc


def _run_job(job: Job) -> tuple[Path, EpisodeSummary, DatasetInfo]:
    if _INIT_ERROR is not None:
        raise _INIT_ERROR
    assert _RUNNER is not None
    result = _RUNNER.run(job)
    assert result is not None
    return result[0], result[1], _RUNNER.info


@dataclass
class CollectResult:
    """What a collection run did."""

    path: Path
    added: list[EpisodeSummary] = field(default_factory=list)
    total: int = 0
    interrupted: bool = False
    seconds: float = 0.0


def check_target(status: DatasetStatus, task: TaskSpec, image_size: int | None) -> None:
    """Refuse to add episodes of ``task`` to a file of another task or image size (before any work)."""
    info = status.info
    if info is None:
        return
    if info.task_id != task.id:
        raise DatasetError(f"{status.path} holds episodes of task {info.task_id}, not {task.id}; choose another --out")
    height = image_size or task.cameras.height
    width = image_size or task.cameras.width
    if (info.image_height, info.image_width) != (height, width):
        raise DatasetError(
            f"{status.path} has {info.image_height}x{info.image_width} images, not {height}x{width}; "
            f"pass --image-size {info.image_height} to add to it"
        )


def _check_picklable(factory: Callable[[], Expert]) -> None:
    try:
        pickle.dumps(factory)
    except Exception as exc:
        raise PipetteError(
            f"--workers > 1 needs an expert factory that can be pickled ({exc}); use a module-level class"
        ) from None


def _accept(status: DatasetStatus, info: DatasetInfo, tmp: Path) -> None:
    why = status.info.mismatch(info) if status.info is not None else None
    if why is not None:
        tmp.unlink(missing_ok=True)
        raise DatasetError(f"cannot add to {status.path}: {why}")
    status.info = info


def collect(
    task: TaskSpec,
    out: Path,
    *,
    episodes: int,
    seed: int = 0,
    image_size: int | None = None,
    workers: int = 1,
    expert_factory: Callable[[], Expert] | None = None,
    max_steps: int | None = None,
    render_profile: str = "fast",
    on_start: Callable[[int, int], None] | None = None,
    on_episode: Callable[[EpisodeSummary], None] | None = None,
    stop: Callable[[], bool] = lambda: False,
) -> CollectResult:
    """Record scripted episodes of ``task`` until ``out`` holds ``episodes`` of them.

    Args:
        task: The task.
        out: The dataset file; created, or resumed if it (or its parts) exist.
        episodes: Total episodes wanted in the file.
        seed: Seed of episode 0; episode ``i`` uses ``seed + i``.
        image_size: Square image side (default: the task's cameras).
        workers: Processes recording episodes in parallel.
        expert_factory: Builds the expert (default: the task's skill program,
            :func:`~pipette_cli.demos.experts.base.find_expert`); must be
            picklable when ``workers > 1``.
        max_steps: Control-step cap per episode (default: :func:`step_cap`).
        render_profile: ``fast`` or ``full``.
        on_start: Called with ``(episodes already in the file, episodes to record)``.
        on_episode: Called after each episode is safely on disk.
        stop: Polled between steps; when true the current episode is dropped and the run
            packs what it has and returns with ``interrupted``.

    Raises:
        DatasetError: ``out`` is unreadable or belongs to another task or image size.
        PipetteError: no expert for the task.
    """
    out = Path(out)
    if episodes < 0 or workers < 1:
        raise PipetteError("--episodes must be >= 0 and --workers >= 1")
    started = time.perf_counter()
    with writing(out):  # a second run on this file stops here
        status = scan(out)
        check_target(status, task, image_size)
        have = len(status.episodes)
        jobs = [
            Job(have + i, s, part_path(out, have + i))
            for i, s in enumerate(plan_seeds(status.seeds, seed + have, episodes - have))
        ]
        if jobs and have and (mixing := mixing_problem(status, task)) is not None:
            raise DatasetError(mixing)
        result = CollectResult(out, total=have)
        if expert_factory is None and jobs:
            find_expert(task)  # fail fast, before building anything
        if workers > 1 and expert_factory is not None:
            _check_picklable(expert_factory)
        clean(status)
        if on_start is not None:
            on_start(have, len(jobs))
        try:
            if jobs:
                attrs = dict(provenance(task))
                kwargs = dict(
                    task=task,
                    image_size=image_size,
                    render_profile=render_profile,
                    expert_factory=expert_factory,
                    attrs=attrs,
                    max_steps=max_steps or step_cap(task),
                    source="scripted",
                )
                runs = _in_process(kwargs, jobs, stop) if workers == 1 else _in_pool(kwargs, jobs, workers, stop)
                try:
                    for job, outcome in runs:
                        if outcome is None:
                            result.interrupted = True
                            break
                        tmp, summary, info = outcome
                        _accept(status, info, tmp)
                        commit_tmp(tmp, job.part)
                        result.added.append(summary)
                        result.total += 1
                        if on_episode is not None:
                            on_episode(summary)
                finally:
                    runs.close()  # releases the env or terminates the pool
        finally:
            clean(scan(out))
            pack(out)
        result.seconds = time.perf_counter() - started
        return result


Outcome = tuple[Path, EpisodeSummary, DatasetInfo] | None


def _in_process(
    kwargs: dict[str, Any], jobs: list[Job], stop: Callable[[], bool]
) -> Generator[tuple[Job, Outcome], None, None]:
    runner = EpisodeRunner(**kwargs)
    try:
        for job in jobs:
            if stop():
                yield job, None
                return
            done = runner.run(job, stop)
            yield job, None if done is None else (*done, runner.info)
    finally:
        runner.close()


def _in_pool(
    kwargs: dict[str, Any], jobs: list[Job], workers: int, stop: Callable[[], bool]
) -> Generator[tuple[Job, Outcome], None, None]:
    return ordered_pool(_init_worker, (kwargs,), _run_job, jobs, workers, stop)


class Interrupt:
    """A flag set by Ctrl-C (SIGINT) or SIGTERM, polled by a run so that it stops between steps
    and keeps what it finished; calling it says whether it is set."""

    def __init__(self) -> None:
        self._event = threading.Event()
        self.signum: int | None = None
        """The first signal received (``signal.SIGINT`` or ``signal.SIGTERM``), None before one."""

    def __call__(self) -> bool:
        return self._event.is_set()

    def set(self, signum: int) -> None:
        if self._event.is_set():
            log.warning("still finishing: writing what was recorded so far")
            return
        self.signum = signum
        self._event.set()

    @property
    def exit_code(self) -> int:
        """The shell's code for the signal: 130 for Ctrl-C, 143 for SIGTERM."""
        return 128 + int(self.signum or signal.SIGINT)


@contextmanager
def deferred_interrupt() -> Iterator[Interrupt]:
    """Turn Ctrl-C (SIGINT) and SIGTERM into a flag the caller polls, so a run stops between steps
    and packs its episodes (a second signal only warns; SIGKILL cannot be deferred)."""
    flag = Interrupt()
    if threading.current_thread() is not threading.main_thread():
        yield flag
        return

    def handler(signum: int, frame: object) -> None:
        flag.set(signum)

    previous = {signum: signal.signal(signum, handler) for signum in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield flag
    finally:
        for signum, before in previous.items():
            signal.signal(signum, before)
