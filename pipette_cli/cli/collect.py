"""``pipette collect``: record scripted or teleoperated demonstrations into an HDF5 file."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer

from pipette_cli.cli.common import RobotOption, err_console, load_task, out_console, show_progress, spec_default
from pipette_cli.demos.collect import collect as collect_episodes
from pipette_cli.demos.collect import deferred_interrupt
from pipette_cli.demos.recorder import EpisodeSummary
from pipette_cli.demos.teleop import DEFAULT_KEYS, teleop_collect
from pipette_cli.errors import PipetteError, plural
from pipette_cli.sim.render import PROFILES
from pipette_cli.specs.task import CamerasSpec


class Source(str, Enum):
    scripted = "scripted"
    teleop = "teleop"


def collect(
    task_id: Annotated[str, typer.Argument(help="Task id, e.g. PickUpTestTube.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="HDF5 file to create or add to.")],
    source: Annotated[
        Source, typer.Option("--source", help="scripted (the task's expert) or teleop (keyboard, needs a display).")
    ] = Source.scripted,
    episodes: Annotated[
        int, typer.Option("--episodes", "-n", min=0, help="Episodes the file should hold in the end (a rerun resumes).")
    ] = 10,
    seed: Annotated[int, typer.Option("--seed", help="Seed of episode 0; episode i uses seed + i.")] = 0,
    image_size: Annotated[
        int | None,
        typer.Option(
            "--image-size",
            min=16,
            max=4096,
            help=f"Square image side in pixels (default: the task's cameras, {spec_default(CamerasSpec, 'width')}).",
        ),
    ] = None,
    workers: Annotated[
        int, typer.Option("--workers", "-w", min=1, help="Processes recording episodes in parallel (scripted only).")
    ] = 1,
    max_steps: Annotated[
        int | None,
        typer.Option("--max-steps", min=1, help="Control-step cap per episode (default: the task's timeout + 1 s)."),
    ] = None,
    profile: Annotated[str, typer.Option("--profile", help=f"Render profile: {' or '.join(PROFILES)}.")] = "fast",
    robot: RobotOption = None,
) -> None:
    """Record demonstrations of a task: per control step three RGB views, state, action and
    simulator state; per episode the verdict and provenance (docs/data_format.md).

    Ctrl-C or a crash never damages recorded episodes; rerunning the same command resumes.

    Example: pipette collect PickUpTestTube --robot ur5e_2f85 --episodes 50 --out tube_ur5e.h5 --workers 4
    """
    spec = load_task(task_id, robot, check_limits=True)
    if source is Source.teleop and workers != 1:
        raise PipetteError("--workers applies to --source scripted only; teleoperation runs one episode at a time")

    ok = failed = 0
    progress = show_progress(f"collect {spec.short_name}", "episodes")

    def started(have: int, todo: int) -> None:  # after the file and the expert were checked
        if have:
            err_console.print(f"{out}: {plural(have, 'episode')} already recorded; {todo} to go", soft_wrap=True)
        progress.start(todo)

    def finished(summary: EpisodeSummary) -> None:
        nonlocal ok, failed
        ok, failed = ok + summary.success, failed + (not summary.success)
        progress.update(advance=1, note=f"[green]{ok} ok[/green] [red]{failed} failed[/red]")

    try:
        with deferred_interrupt() as interrupted:
            if source is Source.teleop:
                err_console.print(
                    "keys: " + ", ".join(f"{k} {what}" for k, what in DEFAULT_KEYS.describe()), soft_wrap=True
                )
                result = teleop_collect(
                    spec,
                    out,
                    episodes=episodes,
                    seed=seed,
                    image_size=image_size,
                    max_steps=max_steps,
                    on_start=started,
                    on_episode=finished,
                    stop=interrupted,
                    on_done=lambda v: err_console.print(
                        f"episode {'succeeded' if v.success else 'failed: ' + str(v.reason or 'step cap')}; "
                        "Enter saves, Delete discards, Home retries",
                        soft_wrap=True,
                    ),
                )
            else:
                result = collect_episodes(
                    spec,
                    out,
                    episodes=episodes,
                    seed=seed,
                    image_size=image_size,
                    workers=workers,
                    max_steps=max_steps,
                    render_profile=profile,
                    on_start=started,
                    on_episode=finished,
                    stop=interrupted,
                )
    finally:
        progress.stop()
    added = len(result.added)
    rate = f"{added / result.seconds * 60:.1f} episodes/min" if added and result.seconds else ""
    successes = sum(s.success for s in result.added)
    summary = (
        f"{out}: {plural(result.total, 'episode')} ({added} new, {successes} successful{', ' + rate if rate else ''})"
        if added
        else f"{out}: {plural(result.total, 'episode')}, all recorded before (nothing new to collect)"
    )
    if result.interrupted:
        err_console.print(f"interrupted; {summary}; run the same command again to resume", soft_wrap=True)
        raise typer.Exit(interrupted.exit_code)
    out_console.print(summary)
