"""Run a checked plan step by step: each command in its own process, each answer here.

Every CLI step runs as ``python -m pipette_cli.cli.main ARGS`` (never a shell), with a progress
bar that shows the step's latest line of output and its elapsed time; its results (stdout)
are shown when it ends. The first step that fails stops the plan with an error naming the step,
its exit code and its last error line; Ctrl-C interrupts the running step the way Ctrl-C
interrupts that command (they are all safe to interrupt) and stops the plan. A server step
(``serve``) followed by more steps keeps running beside them once it says it is ready, and is
stopped (Ctrl-C) when the plan ends.
"""

from __future__ import annotations

import collections
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

from pipette_cli.agent.answers import Answer, answer
from pipette_cli.agent.catalog import AgentError, CommandCatalog
from pipette_cli.agent.plan import CheckedPlan, CheckedStep
from pipette_cli.registry import Registry


class StepFailed(AgentError):
    """A step of a plan failed; the steps before it finished, the ones after it did not run."""


@dataclass
class StepResult:
    index: int
    command: str
    argv: list[str]
    code: int
    seconds: float
    stdout: str = ""
    tail: list[str] = field(default_factory=list)
    answer: Answer | None = None


def step_argv(plan: CheckedPlan, step: CheckedStep, catalog: CommandCatalog) -> list[str]:
    """The step's ``pipette`` arguments, earlier steps' outputs filled in."""
    return catalog.argv(step.command, plan.resolved_args(step))


def _pump(stream: IO[str], sink: queue.Queue[tuple[str, str | None]], name: str) -> None:
    for line in stream:
        sink.put((name, line.rstrip("\n")))
    sink.put((name, None))


class PlanRunner:
    """Runs a plan's steps in order, drawing progress on ``console`` (stderr)."""

    def __init__(
        self,
        catalog: CommandCatalog,
        console: Console,
        *,
        global_args: Sequence[str] = (),
        show_output: Callable[[str], None] | None = None,
        show_answer: Callable[[Answer], None] | None = None,
        background: dict[str, str] | None = None,
        registry: Registry | None = None,
        python: str = sys.executable,
    ) -> None:
        self.catalog = catalog
        self.registry = registry
        self.background = background or {}
        """Commands that keep running (``serve``) -> the start of the output line that says they
        are ready; followed by more steps, they run beside them and are stopped at the end."""
        self._running: list[subprocess.Popen[str]] = []
        self.console = console
        self.global_args = list(global_args)
        self.show_output = show_output
        self.show_answer = show_answer
        self.python = python

    def run(self, plan: CheckedPlan) -> list[StepResult]:
        """Run every step; return their results.

        Raises:
            AgentError: the plan still misses values.
            StepFailed: a step failed (the message names it and why).
        """
        if not plan.runnable:
            raise AgentError(f"the plan still misses values: {plan.missing}")
        try:
            return self._run(plan)
        finally:
            self._stop_background()

    def _run(self, plan: CheckedPlan) -> list[StepResult]:
        results: list[StepResult] = []
        total = len(plan.steps)
        for step in plan.steps:
            label = f"step {step.index}/{total}"
            if self.catalog.get(step.command).is_answer:
                started = time.perf_counter()
                found = answer(step.command, plan.resolved_args(step), self.registry)
                results.append(
                    StepResult(step.index, step.command, [step.command], 0, time.perf_counter() - started, answer=found)
                )
                if self.show_answer:
                    self.show_answer(found)
                continue
            argv = step_argv(plan, step, self.catalog)
            ready = self.background.get(step.command) if step.index < total else None
            result = self._run_command(label, step, argv, ready)
            results.append(result)
            if self.show_output and result.stdout.strip():
                self.show_output(result.stdout)
            if result.code != 0:
                why = next((line for line in reversed(result.tail) if line.strip()), "no output")
                raise StepFailed(
                    f"step {step.index} (pipette {' '.join(argv)}) failed with exit code {result.code}: "
                    f"{why.removeprefix('error: ')}"
                    + (f"; steps {step.index + 1}-{total} did not run" if step.index < total else "")
                )
        return results

    def _stop_background(self) -> None:
        for process in self._running:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()
        self._running.clear()

    def _run_command(self, label: str, step: CheckedStep, argv: list[str], ready: str | None = None) -> StepResult:
        command = [self.python, "-m", "pipette_cli.cli.main", *self.global_args, *argv]
        env = {**os.environ, "PYTHONUNBUFFERED": "1", "COLUMNS": os.environ.get("COLUMNS", "120")}
        started = time.perf_counter()
        tail: collections.deque[str] = collections.deque(maxlen=20)
        out: list[str] = []
        lines: queue.Queue[tuple[str, str | None]] = queue.Queue()
        columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn())
        title = f"{label} pipette {' '.join(argv)}"
        with Progress(*columns, console=self.console, transient=False) as progress:
            bar = progress.add_task(_short(title), total=None)
            process = subprocess.Popen(
                command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, bufsize=1, env=env, cwd=Path.cwd()
            )
            readers = [
                threading.Thread(target=_pump, args=(stream, lines, name), daemon=True)
                for stream, name in ((process.stdout, "out"), (process.stderr, "err"))
            ]
            for reader in readers:
                reader.start()
            open_streams = 2
            try:
                while open_streams:
                    try:
                        name, line = lines.get(timeout=0.2)
                    except queue.Empty:
                        continue
                    if line is None:
                        open_streams -= 1
                        continue
                    if name == "out":
                        out.append(line)
                    if line.strip():
                        tail.append(line)
                        progress.update(bar, description=f"{_short(title)} [dim]{_short(line.strip(), 60)}[/dim]")
                    if ready is not None and name == "out" and line.startswith(ready):
                        break  # a server is up: it runs beside the next steps
                if open_streams and ready is not None:
                    self._running.append(process)
                    code = 0
                else:
                    code = process.wait()
            except KeyboardInterrupt:
                process.send_signal(signal.SIGINT)
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
                raise
            mark = (
                ("[green]running[/green]" if process in self._running else "[green]done[/green]")
                if code == 0
                else f"[red]failed ({code})[/red]"
            )
            progress.update(bar, total=1, completed=1, description=f"{_short(title)} {mark}")
        return StepResult(
            step.index,
            step.command,
            argv,
            code,
            time.perf_counter() - started,
            "\n".join(out) + ("\n" if out else ""),
            list(tail),
        )


def _short(text: str, width: int = 70) -> str:
    return escape(text if len(text) <= width else text[: width - 1] + "…")
