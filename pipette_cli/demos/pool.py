"""An ordered, interruptible process pool shared by ``collect`` and ``augment``."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Generator, Sequence
from typing import Any, TypeVar

J = TypeVar("J")


def ordered_pool(
    init: Callable[..., None],
    init_args: tuple[Any, ...],
    run: Callable[[J], Any],
    jobs: Sequence[J],
    workers: int,
    stop: Callable[[], bool],
) -> Generator[tuple[J, Any], None, None]:
    """Run ``run(job)`` in ``workers`` spawned processes (each set up by ``init(*init_args)``)
    and yield ``(job, outcome)`` in job order. When ``stop()`` turns true (Ctrl-C deferred by the
    caller) it yields ``(job, None)`` once and stops; the pool is torn down either way."""
    context = multiprocessing.get_context("spawn")
    pool = context.Pool(min(workers, len(jobs)), initializer=init, initargs=init_args)
    try:
        results = pool.imap(run, jobs)  # in order: part k is committed only after part k-1
        for job in jobs:
            while True:
                if stop():
                    yield job, None
                    return
                try:
                    outcome = results.next(timeout=0.2)
                    break
                except multiprocessing.TimeoutError:
                    continue
            yield job, outcome
        pool.close()
    finally:
        pool.terminate()
        pool.join()
