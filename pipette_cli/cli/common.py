"""Shared CLI plumbing: the stderr console, global state, JSON output."""

from __future__ import annotations

import dataclasses
import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from pydantic import BaseModel
from rich.console import Console, ConsoleDimensions
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.text import Text

from pipette_cli.demos.check import placed_on
from pipette_cli.demos.embodiment import on_robot
from pipette_cli.lerobot.layout import policy_folder
from pipette_cli.progress import ProgressLines
from pipette_cli.registry import load_registry, registry_dirs

if TYPE_CHECKING:
    from pipette_cli.specs.task import TaskSpec


class _Console(Console):
    """A rich console that, writing to a file or a pipe (a log, ``| tee``, ``> out.txt``), is wide
    enough that no table cuts an id or a path (rich's default there is 80 columns); ``COLUMNS``
    still sets the width, and a terminal keeps its own."""

    @property
    def size(self) -> ConsoleDimensions:
        size = super().size
        if self._width is None and not self.is_terminal and not os.environ.get("COLUMNS"):
            return ConsoleDimensions(NOT_A_TERMINAL_WIDTH, size.height)
        return size

    @size.setter
    def size(self, new_size: tuple[int, int]) -> None:
        self._width, self._height = new_size


NOT_A_TERMINAL_WIDTH = 320
err_console = _Console(stderr=True, highlight=False)
out_console = _Console(highlight=False, soft_wrap=True)


@dataclass
class GlobalState:
    """Options given before the command (``pipette -v --registry-dir D tasks list``)."""

    verbosity: int = 0
    debug: bool = False
    registry_dirs: list[Path] = field(default_factory=list)


STATE = GlobalState()


def print_json(data: Any) -> None:
    """Write ``data`` as JSON to stdout (machine output, no rich markup)."""
    sys.stdout.write(json.dumps(data, indent=2, sort_keys=False, default=str) + "\n")
    sys.stdout.flush()


def _field(model: type, name: str) -> tuple[Any, str]:
    """(default, description) of field ``name`` of a pydantic model (``Field(description=...)``)
    or of a dataclass (``field(metadata={"description": ...})``)."""
    if isinstance(model, type) and issubclass(model, BaseModel):
        info = model.model_fields[name]
        return info.get_default(call_default_factory=True), info.description or ""
    if not dataclasses.is_dataclass(model):
        raise TypeError(f"{model.__name__} is neither a pydantic model nor a dataclass")
    found = {f.name: f for f in dataclasses.fields(model)}[name]
    if found.default is not dataclasses.MISSING:
        default = found.default
    elif found.default_factory is not dataclasses.MISSING:
        default = found.default_factory()
    else:
        raise TypeError(f"{model.__name__}.{name} has no default to bind an option to")
    return default, str(found.metadata.get("description", ""))


def spec_default(model: type, field: str) -> Any:
    """The default of ``model.field`` (a pydantic spec or a dataclass of options): CLI options bound
    to a spec take their default from it, so each default lives once."""
    return _field(model, field)[0]


def spec_help(model: type, field: str, text: str = "") -> str:
    """``text`` followed by the field's own description (units, the paper's symbol and section), as
    a sentence."""
    description = _field(model, field)[1]
    said = f"{text.rstrip('.')} ({description})" if text and description else text or description
    return said if not said or said.endswith(".") else f"{said}."


BACKEND_HELP = (
    "offline (default: a deterministic parser), openai (any OpenAI-compatible server) or ollama; "
    "the same backends for `agent`, `new-task` and `assets new`."
)

RobotOption = Annotated[
    str | None,
    typer.Option(
        "--robot",
        help="Robot to run the task on: panda, piper, ur5e_2f85 or any id of registry/robots "
        "(default: the task's embodiment.robot). The base moves along the bench where needed to reach.",
    ),
]


def load_task(task_id: str, robot: str | None = None, *, check_limits: bool = False) -> TaskSpec:
    """The registry's task ``task_id``, placed on ``robot`` when one is given (a line on stderr says
    where its base moved, if it did); with ``check_limits`` (before recording or running episodes)
    a robot that cannot do the task for a limit of its own is refused up front
    (:func:`~pipette_cli.demos.check.placed_on`).

    Raises:
        TaskNotFound: unknown task.
        SimError: unknown robot (the line lists the robots).
        InfeasibleTask: the robot cannot do the task (the line names the limit).
    """
    task = load_registry(STATE.registry_dirs).get(task_id)
    if robot is None:
        return task

    placed = placed_on(task, robot) if check_limits else on_robot(task, robot)
    before, after = task.embodiment.base.pos, placed.embodiment.base.pos
    if placed.embodiment.robot != task.embodiment.robot and before != after:
        err_console.print(
            f"{placed.embodiment.robot}: base moved from ({before[0]:.2f}, {before[1]:.2f}) to "
            f"({after[0]:.2f}, {after[1]:.2f}) on the bench to reach the task's work points",
            soft_wrap=True,
        )
    return placed


class BarOrLines:
    """One long stage's progress on stderr (:func:`show_progress`): a rich bar (done of total,
    elapsed and remaining time) when stderr is a terminal, else a plain line every few seconds
    (:class:`~pipette_cli.progress.ProgressLines`), so a log of the run shows it; nothing with
    ``--quiet``. A note (``[green]3 ok[/green] 1 failed``) may hold rich markup; lines print it plain.
    """

    def __init__(self, stage: str, unit: str = "", *, bar: bool = True) -> None:
        self.stage = stage
        quiet = STATE.verbosity < 0
        self.bar: Progress | None = None
        self.lines: ProgressLines | None = None
        if err_console.is_terminal:
            if bar and not quiet:
                self.bar = Progress(
                    TextColumn("{task.description}"),
                    BarColumn(),
                    MofNCompleteColumn(),
                    TimeElapsedColumn(),
                    TimeRemainingColumn(),
                    console=err_console,
                )
                self._task = self.bar.add_task(stage, total=None)
        elif not quiet:
            self.lines = ProgressLines(stage, self._emit, unit=unit)

    @staticmethod
    def _emit(line: str) -> None:
        err_console.print(line, markup=False, highlight=False, soft_wrap=True)

    def start(self, total: int | None = None, *, done: int | None = 0) -> None:
        if self.bar is not None:
            self.bar.update(self._task, total=total, completed=done or 0)
            self.bar.start()
        if self.lines is not None:
            self.lines.start(total, done=done)

    def update(
        self, done: int | None = None, *, advance: int = 0, total: int | None = None, note: str | None = None
    ) -> None:
        if self.bar is not None:
            description = None if note is None else f"{self.stage} {note}"
            self.bar.update(self._task, completed=done, advance=advance or None, total=total, description=description)
        if self.lines is not None:
            self.lines.update(
                done, advance=advance, total=total, note=None if note is None else Text.from_markup(note).plain
            )

    def print(self, line: str) -> None:
        """A line above the bar (or between progress lines)."""
        err_console.print(line, soft_wrap=True)

    def stop(self) -> None:
        if self.bar is not None:
            self.bar.stop()
        if self.lines is not None:
            self.lines.stop()

    def __enter__(self) -> BarOrLines:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def show_progress(stage: str, unit: str = "") -> BarOrLines:
    """The progress of a long stage (collect, augment, convert, train, eval) on stderr: a bar in a
    terminal, else a line every few seconds (``PIPETTE_PROGRESS_INTERVAL``); hidden with ``--quiet``.
    A :data:`~pipette_cli.progress.ProgressFactory`."""
    return BarOrLines(stage, unit)


def wrote_task_line(path: Path, task_id: str, verify: bool) -> str:
    """What to do after writing a task file: check it, then use it, with ``--registry-dir`` when its
    folder is not one the registry reads (a task written to ``my_tasks/`` is unknown without it)."""
    searched = [d.resolve() for d in registry_dirs(STATE.registry_dirs)]
    found = any(path.resolve().is_relative_to(d) for d in searched)
    flag = "" if found else f" --registry-dir {path.parent}"
    check = "check the VERIFY fields, then: " if verify else "edit it, then: "
    use = f"; then use it, e.g. pipette{flag} sim render {task_id}"
    away = "" if found else f" ({path.parent} is not a registry folder: give --registry-dir or PIPETTE_REGISTRY_PATH)"
    return f"wrote {path}; {check}pipette tasks validate {path}{use}{away}"


def policy_folder_of(path: Path) -> Path:
    """``--policy``'s LeRobot policy folder (:func:`~pipette_cli.lerobot.layout.policy_folder`: a run
    folder is its last checkpoint), said on stderr when it is not the folder given."""
    found = policy_folder(path)
    if found != Path(path):
        err_console.print(f"policy: {found}", soft_wrap=True)
    return found
