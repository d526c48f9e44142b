"""Where demos are augmented: in this process, a local process pool, or a Ray cluster.

Every executor yields ``(job, result)`` in job order (results may be computed out of order),
so the output file does not depend on the executor or the number of workers. Each worker
builds one :class:`~.pipeline.DemoAugmenter` (a World and, lazily, a GL context) and keeps it
for all its demos. ``stop()`` is polled while waiting: when it turns true the executor stops
handing out work and yields ``(job, None)``.
"""

from __future__ import annotations

import logging
import os
import signal
from collections.abc import Callable, Generator
from typing import Any, Literal

from pipette_cli.augment.pipeline import DemoAugmenter, DemoJob, DemoResult
from pipette_cli.demos.pool import ordered_pool
from pipette_cli.errors import PipetteError

log = logging.getLogger(__name__)

Executor = Literal["local", "ray"]
Outcome = tuple[DemoJob, DemoResult | None]

_AUGMENTER: DemoAugmenter | None = None
_INIT_ERROR: BaseException | None = None


def default_workers() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def share_renderer_threads(workers: int) -> None:
    """Give this worker's software renderer (Mesa llvmpipe) its share of the cores.

    llvmpipe starts one rasterizer thread per core in every process; N workers on N cores would
    run N^2 threads. Must run before the worker's GL context exists; ``LP_NUM_THREADS`` set by
    the user wins. A GPU driver ignores the variable.
    """
    os.environ.setdefault("LP_NUM_THREADS", str(max(1, default_workers() // max(1, workers))))


def _init_worker(kwargs: dict[str, Any], workers: int) -> None:
    global _AUGMENTER, _INIT_ERROR
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    share_renderer_threads(workers)
    try:
        _AUGMENTER = DemoAugmenter(**kwargs)
    except Exception as exc:  # a failing initializer would make the pool respawn forever
        _INIT_ERROR = exc


def _run_job(job: DemoJob) -> DemoResult:
    if _INIT_ERROR is not None:
        raise _INIT_ERROR
    assert _AUGMENTER is not None
    return _AUGMENTER.run(job)


def in_process(kwargs: dict[str, Any], jobs: list[DemoJob], stop: Callable[[], bool]) -> Generator[Outcome, None, None]:
    augmenter = DemoAugmenter(**kwargs)
    try:
        for job in jobs:
            if stop():
                yield job, None
                return
            yield job, augmenter.run(job)
    finally:
        augmenter.close()


def in_pool(
    kwargs: dict[str, Any], jobs: list[DemoJob], workers: int, stop: Callable[[], bool]
) -> Generator[Outcome, None, None]:
    return ordered_pool(_init_worker, (kwargs, min(workers, len(jobs))), _run_job, jobs, workers, stop)


def in_ray(
    kwargs: dict[str, Any], jobs: list[DemoJob], workers: int, stop: Callable[[], bool], address: str | None
) -> Generator[Outcome, None, None]:
    """One Ray actor per worker, each with its own augmenter; part files are written on a
    filesystem every node shares (the output's folder)."""
    try:
        import ray  # deferred: ray (~0.35 s; an optional extra, only for --executor ray)
    except ImportError:
        raise PipetteError("--executor ray needs Ray: pip install 'pipette[ray]' (or pip install ray)") from None
    started = not ray.is_initialized()
    if started:
        options: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False, "ignore_reinit_error": True}
        if address is None:  # a local cluster: keep every Ray service on loopback
            options["_node_ip_address"] = "127.0.0.1"
        ray.init(address=address, **options)
    actor_cls: Any = ray.remote(_RayWorker)
    count = min(workers, len(jobs))
    actors: list[Any] = [actor_cls.remote(kwargs, count) for _ in range(count)]
    try:
        pending: dict[Any, tuple[int, Any]] = {}
        done: dict[int, DemoResult] = {}
        queue = list(enumerate(jobs))
        free = list(actors)
        emitted = 0
        while emitted < len(jobs):
            if stop():
                yield jobs[emitted], None
                return
            while free and queue:
                i, job = queue.pop(0)
                actor = free.pop()
                pending[actor.run.remote(job)] = (i, actor)
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=0.2)
            for ref in ready:
                i, actor = pending.pop(ref)
                done[i] = ray.get(ref)
                free.append(actor)
            while emitted in done:
                yield jobs[emitted], done.pop(emitted)
                emitted += 1
    finally:
        for actor in actors:
            ray.kill(actor)
        if started:
            ray.shutdown()


class _RayWorker:
    def __init__(self, kwargs: dict[str, Any], workers: int) -> None:
        share_renderer_threads(workers)  # assumes the actors share a node; each node's own cores count
        self.augmenter = DemoAugmenter(**kwargs)

    def run(self, job: DemoJob) -> DemoResult:
        return self.augmenter.run(job)


def run_jobs(
    kwargs: dict[str, Any],
    jobs: list[DemoJob],
    *,
    executor: Executor,
    workers: int,
    stop: Callable[[], bool],
    address: str | None = None,
) -> Generator[Outcome, None, None]:
    if executor == "ray":
        return in_ray(kwargs, jobs, workers, stop, address)
    if workers <= 1 or len(jobs) <= 1:
        return in_process(kwargs, jobs, stop)
    return in_pool(kwargs, jobs, workers, stop)
