"""Many evaluation episodes: suites, resume after a crash, parallel workers, a dead server.

:func:`evaluate_runs` plays the planned episodes of one or more task runs
(:class:`TaskRun`: a task, its folder, its :class:`~pipette_cli.evaluation.suites.EpisodePlan` list):

* **Resume.** Each folder's ``run.json`` pins the plan; episodes whose log is already there are
  skipped, the others run (see :mod:`~pipette_cli.evaluation.results`). Killing the run at any
  moment loses at most the episodes in flight, and none is run twice.
* **Workers.** With ``workers > 1`` episodes are shared among that many processes, each with
  its own environment and its own policy (a :class:`PolicySource` builds it: a checkpoint
  loaded in the worker, or a client of one of several servers, worker ``i`` using endpoint
  ``i mod n``). An episode depends only on its seed and instruction, never on the worker that
  ran it or the episodes before it, so any worker count gives the same logs.
* **Dead server.** A worker whose server is unreachable applies the safe hold and reports
  :class:`~pipette_cli.evaluation.evaluate.ServerLost`; the run stops at once (other workers are
  ended, their episodes in flight dropped), partial summaries are written, and ``ServerLost``
  is raised with one line that says what happened and how to resume.

Summaries are rewritten from the episode logs at the end of every run, complete or not.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import queue
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Generator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from pipette_cli.errors import PipetteError, plural
from pipette_cli.evaluation.evaluate import (
    ActionSource,
    EpisodeInterrupted,
    EpisodeLog,
    InProcessSource,
    ServerLost,
    run_episode,
)
from pipette_cli.evaluation.results import (
    checkpoint_record,
    environment_record,
    make_manifest,
    prepare_folder,
    write_episode,
    write_summary,
)
from pipette_cli.evaluation.settings import DecodeConfig, EvalSettings, image_size_problem
from pipette_cli.evaluation.suites import EpisodePlan, adhoc_plan
from pipette_cli.serving.client import PolicyClient
from pipette_cli.serving.protocol import DEFAULT_DEAD_AFTER_S, DEFAULT_DEVICE
from pipette_cli.sim.env import PipetteEnv
from pipette_cli.sim.render import gl_info
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)


class SourceFactory(Protocol):
    """Builds a worker's policy; must pickle when ``workers > 1``."""

    def __call__(self, worker: int, config: DecodeConfig) -> ActionSource: ...


@dataclass(frozen=True)
class PolicySource:
    """Where the policy comes from: a checkpoint folder, or one or more servers.

    Attributes:
        checkpoint: A LeRobot policy folder, loaded by each worker on ``device``.
        endpoints: ``pipette serve`` endpoints; worker ``i`` uses ``endpoints[i % n]``.
        device: Torch device for a checkpoint.
        dead_after_s: How long a server may be unreachable before the run stops.
    """

    checkpoint: Path | None = None
    endpoints: tuple[str, ...] = ()
    device: str = DEFAULT_DEVICE
    dead_after_s: float = DEFAULT_DEAD_AFTER_S

    def __post_init__(self) -> None:
        if (self.checkpoint is None) == (not self.endpoints):
            raise PipetteError("give exactly one of --endpoint (a running `pipette serve`) and --policy (in-process)")

    def __call__(self, worker: int, config: DecodeConfig) -> ActionSource:
        if self.checkpoint is not None:
            return InProcessSource(self.checkpoint, device=self.device)
        heartbeat_ms = max(50, min(1000, int(self.dead_after_s * 200)))
        return PolicyClient(
            self.endpoints[worker % len(self.endpoints)],
            timeout_ms=config.timeout_ms,
            heartbeat_ms=heartbeat_ms,
            dead_after_s=self.dead_after_s,
        )

    def record(self) -> dict[str, Any]:
        """The manifest's ``policy`` entry."""
        if self.checkpoint is not None:
            return checkpoint_record(self.checkpoint)
        return {"kind": "server", "endpoints": list(self.endpoints)}


def check_servers(endpoints: tuple[str, ...], image_hw: tuple[int, int], connect_timeout_s: float) -> None:
    """Before any episode: every server answers, and its policy reads images of the size rendered.

    Raises:
        PipetteError: one line naming the endpoint and what is wrong.
    """
    for endpoint in endpoints:
        with PolicyClient(endpoint, timeout_ms=int(1000 * connect_timeout_s) + 65_000) as client:
            if not client.wait_until_up(connect_timeout_s):
                raise PipetteError(
                    f"no policy server answers at {endpoint} (waited {connect_timeout_s:g} s); "
                    "start `pipette serve` first or fix --endpoint"
                )
            served = client.info()
        problem = image_size_problem(
            served.get("images", {}), image_hw, f"at {endpoint}", "--image-size, or the suite's image_size"
        )
        if problem is not None:
            raise PipetteError(problem)


@dataclass(frozen=True)
class TaskRun:
    """The episodes of one task, written to ``folder``."""

    task: TaskSpec
    folder: Path
    episodes: tuple[EpisodePlan, ...]


@dataclass
class EvalResult:
    """What :func:`evaluate_runs` did."""

    summaries: dict[str, dict[str, Any]] = field(default_factory=dict)
    already_done: int = 0
    new_episodes: int = 0
    interrupted: bool = False
    seconds: float = 0.0


class EpisodeWorker:
    """One policy and one environment at a time (rebuilt when the task changes)."""

    def __init__(self, tasks: dict[str, TaskSpec], source: SourceFactory, settings: EvalSettings, index: int) -> None:
        self.tasks, self.settings = tasks, settings
        self.source = source(index, settings.config)
        self.env: PipetteEnv | None = None
        self.environment: dict[str, Any] | None = None

    def run(self, plan: EpisodePlan, stop: Callable[[], bool] | None = None) -> EpisodeLog:
        if self.env is None or self.env.task.id != plan.task:
            self.close_env()
            self.env = PipetteEnv(
                self.tasks[plan.task],
                image_size=self.settings.image_size,
                render_profile=self.settings.render_profile,  # type: ignore[arg-type]  # a suite's profile is validated
            )
        episode = run_episode(
            self.env,
            self.source,
            self.settings.config,
            episode=plan.index,
            seed=plan.seed,
            instruction=plan.instruction,
            stop=stop,
            conditions=plan.conditions,
        )
        if self.environment is None:
            self.environment = environment_record(gl_info())  # after a render: the GL context is current
        episode.environment = self.environment
        return episode

    def close_env(self) -> None:
        if self.env is not None:
            self.env.close()
            self.env = None

    def close(self) -> None:
        self.close_env()
        close = getattr(self.source, "close", None)
        if callable(close):
            close()


Outcome = tuple[str, int, Any]
"""``("done", run, EpisodeLog)``, ``("lost", run, record)`` or ``("stopped", -1, None)``."""


def evaluate_runs(
    runs: list[TaskRun],
    source: SourceFactory,
    settings: EvalSettings,
    *,
    workers: int = 1,
    on_start: Callable[[int, int], None] | None = None,
    on_episode: Callable[[EpisodeLog], None] | None = None,
    stop: Callable[[], bool] = lambda: False,
) -> EvalResult:
    """Play every planned episode not yet logged; write logs and summaries.

    Args:
        runs: The task runs (folders must differ).
        source: Builds each worker's policy (a :class:`PolicySource`, or any picklable factory).
        settings: Decoding, image size, render profile, dataset version, suite record.
        workers: Processes playing episodes; 1 plays them in this process.
        on_start: Called with ``(episodes already logged, episodes to play)``.
        on_episode: Called with each finished episode's log, once it is on disk.
        stop: Polled; when true the run stops (episodes in flight are dropped) with ``interrupted``.

    Raises:
        ServerLost: the policy server became unreachable; summaries of what finished were written.
        DatasetError: a folder holds another run.
    """
    started = time.perf_counter()
    if workers < 1:
        raise PipetteError("--workers must be at least 1")
    policy = source.record() if isinstance(source, PolicySource) else {"kind": type(source).__name__}
    todo: list[tuple[int, EpisodePlan]] = []
    result = EvalResult()
    for i, run in enumerate(runs):
        manifest = make_manifest(
            run.task,
            list(run.episodes),
            suite=settings.suite,
            image_size=settings.image_size,
            render_profile=settings.render_profile,
            policy=policy,
            config=settings.config,
            dataset_version=settings.dataset_version,
        )
        done = prepare_folder(run.folder, manifest)
        result.already_done += sum(plan.index in done for plan in run.episodes)
        todo += [(i, plan) for plan in run.episodes if plan.index not in done]
    if on_start is not None:
        on_start(result.already_done, len(todo))
    lost: dict[str, Any] | None = None
    try:
        if todo:
            tasks = {run.task.id: run.task for run in runs}
            played = (
                _inline(tasks, source, settings, todo, stop)
                if workers == 1
                else _in_workers(tasks, source, settings, todo, workers, stop)
            )
            try:
                for kind, i, payload in played:
                    if kind == "stopped":
                        result.interrupted = True
                        break
                    if kind == "lost":
                        lost = payload
                        break
                    write_episode(runs[i].folder, payload)
                    result.new_episodes += 1
                    if on_episode is not None:
                        on_episode(payload)
            finally:
                played.close()
    finally:
        for run in runs:
            summary = write_summary(run.folder, stopped=lost)
            if summary is not None:
                result.summaries[run.task.id] = summary
        result.seconds = time.perf_counter() - started
    if lost is not None:
        finished = result.already_done + result.new_episodes
        planned = sum(len(run.episodes) for run in runs)
        raise ServerLost(
            f"{lost['message']}; safe hold applied in {lost['task']} episode {lost['episode']}; "
            f"stopped after {finished} of {plural(planned, 'episode')} (partial summary written); "
            "rerun the same command to resume once the server is back",
            lost,
        )
    return result


def evaluate_task(
    task: TaskSpec,
    source: SourceFactory,
    config: DecodeConfig,
    *,
    episodes: int,
    seed: int,
    out: Path,
    image_size: int | None = None,
    dataset_version: str = "raw",
    workers: int = 1,
    on_start: Callable[[int, int], None] | None = None,
    on_episode: Callable[[EpisodeLog], None] | None = None,
) -> dict[str, Any]:
    """``episodes`` episodes of one task (seeds ``seed + i``, the task's instruction) into ``out``,
    resuming what is there; returns the summary (see :func:`evaluate_runs`, which calls
    ``on_start`` and ``on_episode``)."""
    run = TaskRun(task, Path(out), tuple(adhoc_plan(task, episodes, seed)))
    settings = EvalSettings(config, image_size, dataset_version=dataset_version)
    played = evaluate_runs([run], source, settings, workers=workers, on_start=on_start, on_episode=on_episode)
    return played.summaries[task.id]


def _inline(
    tasks: dict[str, TaskSpec],
    source: SourceFactory,
    settings: EvalSettings,
    todo: list[tuple[int, EpisodePlan]],
    stop: Callable[[], bool],
) -> Generator[Outcome, None, None]:
    worker = EpisodeWorker(tasks, source, settings, 0)
    try:
        for i, plan in todo:
            if stop():
                yield "stopped", -1, None
                return
            try:
                yield "done", i, worker.run(plan, stop)
            except ServerLost as exc:
                yield "lost", i, exc.record
                return
            except EpisodeInterrupted:
                yield "stopped", -1, None
                return
    finally:
        worker.close()


def _in_workers(
    tasks: dict[str, TaskSpec],
    source: SourceFactory,
    settings: EvalSettings,
    todo: list[tuple[int, EpisodePlan]],
    workers: int,
    stop: Callable[[], bool],
) -> Generator[Outcome, None, None]:
    context = multiprocessing.get_context("spawn")
    jobs, results = context.Queue(), context.Queue()
    count = min(workers, len(todo))
    for job in todo:
        jobs.put(job)
    for _ in range(count):
        jobs.put(None)
    threads = max(1, (os.cpu_count() or 1) // count)
    procs = [
        context.Process(target=_worker_main, args=(w, tasks, source, settings, threads, jobs, results), daemon=True)
        for w in range(count)
    ]
    for proc in procs:
        proc.start()
    remaining = len(todo)
    try:
        while remaining:
            if stop():
                yield "stopped", -1, None
                return
            try:
                kind, i, payload = results.get(timeout=0.2)
            except queue.Empty:
                for w, proc in enumerate(procs):
                    if proc.exitcode not in (None, 0):
                        raise PipetteError(
                            f"evaluation worker {w} died (exit code {proc.exitcode}); rerun the same command to resume"
                        ) from None
                continue
            if kind == "error":
                raise (
                    payload
                    if isinstance(payload, PipetteError)
                    else RuntimeError(f"evaluation worker failed:\n{payload}")
                )
            yield kind, i, payload
            if kind == "lost":
                return
            remaining -= 1
    finally:
        for proc in procs:
            if proc.is_alive():
                proc.terminate()
        for proc in procs:
            proc.join(5)


def _worker_main(
    index: int,
    tasks: dict[str, TaskSpec],
    source: SourceFactory,
    settings: EvalSettings,
    threads: int,
    jobs: Any,
    results: Any,
) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C and ends the workers
    parent = os.getppid()
    threading.Thread(target=_exit_with_parent, args=(parent,), daemon=True).start()
    try:
        worker = EpisodeWorker(tasks, source, settings, index)
        _limit_threads(threads)
    except Exception as exc:
        results.put(("error", -1, _portable(exc)))
        return
    try:
        while (job := jobs.get()) is not None:
            i, plan = job
            try:
                results.put(("done", i, worker.run(plan)))
            except ServerLost as exc:
                results.put(("lost", i, exc.record))
                return
            except Exception as exc:
                results.put(("error", i, _portable(exc)))
                return
    finally:
        worker.close()


def _portable(exc: Exception) -> Any:
    """A worker's exception as the parent re-raises it: Pipette errors as such, others as text."""
    return PipetteError(str(exc)) if isinstance(exc, PipetteError) else traceback.format_exc()


def _exit_with_parent(parent: int) -> None:
    """End this worker when the process that started it is gone (killed, not only stopped)."""
    while os.getppid() == parent:
        time.sleep(1.0)
    os._exit(1)


def _limit_threads(threads: int) -> None:
    """Share the CPU among workers: torch would otherwise start one thread per core in each."""
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(threads)
