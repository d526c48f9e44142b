"""Progress of a long stage (collect, augment, convert, train, eval) as plain lines, for logs.

A rich progress bar draws nothing useful into a file (``pipette demo > log.txt 2>&1``): it redraws
one line in place and, without a terminal, prints only its last state. :class:`ProgressLines`
instead emits one self-contained line every few seconds, while the stage runs::

    train: 120/300 steps (40 %), 1m02s elapsed, 1.94 steps/s, eta 1m33s
    collect: 12/20 episodes (60 %), 25 s elapsed, 0.48 episodes/s, eta 17 s; 11 ok 1 failed

A heartbeat thread emits even when nothing advances (a training run loading its dataset, a long
episode), so a log never goes quiet for longer than the interval. The interval is ``interval_s``,
else ``PIPETTE_PROGRESS_INTERVAL`` (seconds), else :data:`DEFAULT_INTERVAL_S`.

:class:`StageProgress` is what a stage reports to; :data:`ProgressFactory` makes one per stage
(the CLI's draws a bar in a terminal and lines otherwise).
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from typing import Protocol

DEFAULT_INTERVAL_S = 10.0
"""Seconds between two progress lines (``PIPETTE_PROGRESS_INTERVAL`` overrides it)."""


class StageProgress(Protocol):
    """What a long stage reports to: its total, then what is done (and a short note)."""

    def start(self, total: int | None = None, *, done: int | None = 0) -> None:
        """The stage begins: ``total`` items (None: unknown), ``done`` of them already (None: the
        first update says)."""

    def update(
        self, done: int | None = None, *, advance: int = 0, total: int | None = None, note: str | None = None
    ) -> None:
        """``done`` items so far (or ``advance`` more), a new ``total``, a note (``3 ok 1 failed``)."""

    def stop(self) -> None:
        """The stage ended (completed or not)."""


ProgressFactory = Callable[[str, str], StageProgress]
"""``(stage, unit) -> StageProgress``, e.g. ``("train", "steps")``."""


def progress_interval(interval_s: float | None = None) -> float:
    """``interval_s``, else ``PIPETTE_PROGRESS_INTERVAL``, else :data:`DEFAULT_INTERVAL_S` (seconds)."""
    if interval_s is not None:
        return interval_s
    try:
        return float(os.environ.get("PIPETTE_PROGRESS_INTERVAL", DEFAULT_INTERVAL_S))
    except ValueError:
        return DEFAULT_INTERVAL_S


def duration(seconds: float) -> str:
    """``42 s``, ``3m05s``, ``1h02m``."""
    s = max(0, round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{s % 3600 // 60:02d}m"


class ProgressLines:
    """A :class:`StageProgress` that emits a line (stage, done/total, elapsed, rate, eta, note)
    at most every ``interval_s`` seconds on updates, at least that often from a heartbeat thread
    while started, and at :meth:`stop` the final state (unless the last line showed it).

    Args:
        stage: What runs (``collect``, ``train HoldTube``).
        emit: Where a line goes (a logger, a console's print).
        unit: What is counted (``episodes``, ``steps``).
        interval_s: Seconds between lines (default: :func:`progress_interval`).
        clock: Monotonic seconds (tests pass a fake one).
        heartbeat: Run the thread that emits while nothing advances.
    """

    def __init__(
        self,
        stage: str,
        emit: Callable[[str], None],
        *,
        unit: str = "",
        interval_s: float | None = None,
        clock: Callable[[], float] = time.monotonic,
        heartbeat: bool = True,
    ) -> None:
        self.stage, self.emit, self.unit, self.clock = stage, emit, unit, clock
        self.interval_s = progress_interval(interval_s)
        self.heartbeat = heartbeat
        self.total: int | None = None
        self.done = 0
        self.note = ""
        self._base: int | None = 0
        self._started: float | None = None
        self._last: float | None = None
        self._shown: tuple[int, int | None, str] | None = None
        """(done, total, note) of the last line emitted: the final line is not a repeat of it."""
        self._lock = threading.Lock()
        self._ended = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, total: int | None = None, *, done: int | None = 0) -> None:
        with self._lock:
            self.total, self._started = total, self.clock()
            self.done, self._base = done or 0, done
            self._last = self._started
        if self.heartbeat and self._thread is None and self.interval_s > 0:
            self._thread = threading.Thread(target=self._beat, name=f"progress {self.stage}", daemon=True)
            self._thread.start()

    def update(
        self, done: int | None = None, *, advance: int = 0, total: int | None = None, note: str | None = None
    ) -> None:
        with self._lock:
            if self._started is None:
                self._started = self._last = self.clock()
            if total is not None:
                self.total = total
            if done is not None:
                self.done = done
                if self._base is None:
                    self._base = done
            self.done += advance
            if note is not None:
                self.note = note
            line = self._due()
        if line:
            self.emit(line)

    def stop(self) -> None:
        self._ended.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        with self._lock:
            fresh = self._started is not None and self._shown != (self.done, self.total, self.note)
            line = self.line() if fresh else ""
            self._started = None
        if line:
            self.emit(line)

    def __enter__(self) -> ProgressLines:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def line(self) -> str:
        """The stage's progress now, as one line."""
        now = self.clock()
        elapsed = now - (self._started if self._started is not None else now)
        unit = f" {self.unit}" if self.unit else ""
        parts = [f"{self.stage}: {self.done}/{self.total}{unit}" if self.total else f"{self.stage}: {self.done}{unit}"]
        if self.total:
            parts[0] += f" ({100 * min(self.done, self.total) // self.total} %)"
        parts.append(f"{duration(elapsed)} elapsed")
        gained = self.done - (self._base if self._base is not None else self.done)
        if gained > 0 and elapsed > 0:
            rate = gained / elapsed
            parts.append(f"{rate:.3g}{unit}/s" if rate >= 0.1 else f"{60 * rate:.3g}{unit}/min")
            if self.total and self.total > self.done:
                parts.append(f"eta {duration((self.total - self.done) / rate)}")
        return ", ".join(parts) + (f"; {self.note}" if self.note else "")

    def _due(self) -> str:
        """The line to emit now, if the interval has passed since the last one (lock held)."""
        if self._started is None or self._last is None:
            return ""
        now = self.clock()
        if now - self._last < self.interval_s:
            return ""
        self._last = now
        self._shown = (self.done, self.total, self.note)
        return self.line()

    def _beat(self) -> None:
        while not self._ended.wait(min(self.interval_s, 1.0) if self.interval_s >= 0.05 else 0.05):
            with self._lock:
                line = self._due()
            if line:
                self.emit(line)
