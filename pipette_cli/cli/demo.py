"""``pipette demo``: the end-to-end pipeline on one task (README command 1)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from pipette_cli.cli.common import RobotOption, err_console, load_task, out_console, print_json, show_progress
from pipette_cli.demo import DEFAULT_TASK, FAST, FULL, next_steps, run_demo, summary_rows, verdict_line


def demo(
    task_id: Annotated[str, typer.Option("--task", help="Task to run the pipeline on.")] = DEFAULT_TASK,
    out: Annotated[Path, typer.Option("--out", "-o", help="Empty folder for every artefact.")] = Path("demo_run"),
    fast: Annotated[
        bool,
        typer.Option(
            "--fast",
            help=f"Smoke run (CI): {FAST.demos} demos, {FAST.image_size} px, {FAST.train_steps} training steps, "
            f"{FAST.eval_episodes} evaluation episodes; trains no usable policy (default: {FULL.demos} demos, "
            f"{FULL.image_size} px, {FULL.train_steps} steps, {FULL.eval_episodes} episodes).",
        ),
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    robot: RobotOption = None,
) -> None:
    """Scripted demos -> success-verified augmentation -> LeRobot dataset -> ACT training ->
    evaluation, on one task, on a CPU (5-7 minutes on 2 cores); prints a summary table, where
    the dataset, videos and plots are, and whether the learned policy works. Exits 1 when the
    policy succeeds in fewer than half of its evaluation episodes. Each stage shows a progress bar,
    or, when stderr is not a terminal (`pipette demo > log.txt 2>&1`), a line every 10 s.

    Example: pipette demo --robot ur5e_2f85 --out demo_run
    """
    task = load_task(task_id, robot, check_limits=True)
    report = run_demo(
        task,
        out,
        FAST if fast else FULL,
        say=lambda line: err_console.print(line, soft_wrap=True),
        progress=show_progress,
    )
    if as_json:
        print_json(report)
    else:
        table = Table(title=f"pipette demo ({'fast' if fast else 'full'}) -> {out}")
        table.add_column("stage")
        table.add_column("result", overflow="fold")
        for key, value in summary_rows(report):
            table.add_row(key, value)
        out_console.print(table)
    line = verdict_line(report)
    if report["learned"] is False:
        err_console.print(f"[bold red]{line}[/]", soft_wrap=True)
        raise typer.Exit(1)
    err_console.print(f"[bold green]{line}[/]" if report["learned"] else line, soft_wrap=True)
    if report["learned"]:
        err_console.print(next_steps(report), markup=False, soft_wrap=True)
