"""``pipette experts``: check the scripted experts' success rates (no rendering)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from pipette_cli.cli.common import STATE, RobotOption, err_console, load_task, out_console, print_json
from pipette_cli.demos.check import ExpertReport, check_expert, step_of
from pipette_cli.errors import plural
from pipette_cli.registry import load_registry

app = typer.Typer(
    help="Scripted experts.\n\nExample: pipette experts check PickUpTestTube --episodes 50", no_args_is_help=True
)


def markdown_table(reports: list[ExpertReport]) -> str:
    lines = [
        "| task | episodes | success | rate | failures (reason: count) | seconds |",
        "| --- | ---: | ---: | ---: | --- | ---: |",
    ]
    for r in reports:
        failures = ", ".join(f"{k}: {v}" for k, v in r.failures.most_common()) or "-"
        lines.append(
            f"| {r.task_id} | {r.episodes} | {r.successes} | {100 * r.success_rate:.0f} % | {failures} | {r.seconds:.0f} |"
        )
    return "\n".join(lines) + "\n"


@app.command("check")
def check(
    tasks: Annotated[list[str] | None, typer.Argument(help="Task ids (default: every registered task).")] = None,
    episodes: Annotated[int, typer.Option("--episodes", "-n", min=1, help="Seeds per task.")] = 50,
    seed: Annotated[int, typer.Option("--seed", help="First seed.")] = 0,
    markdown: Annotated[Path | None, typer.Option("--markdown", help="Also write the table as markdown here.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
    robot: RobotOption = None,
) -> None:
    """Run each task's scripted expert on N seeds (physics only) and tabulate success.

    Example: pipette experts check PickUpTestTube --robot piper --episodes 20
    """
    registry = load_registry(STATE.registry_dirs)
    ids = [registry.get(t).id for t in tasks] if tasks else registry.ids()
    reports = []
    for task_id in ids:
        report = check_expert(load_task(task_id, robot), episodes, seed)
        err_console.print(
            f"{task_id}: {report.successes}/{report.episodes} in {report.seconds:.0f} s", soft_wrap=True, markup=False
        )
        for failed_seed, why in report.expert_failures.items():
            err_console.print(f"  seed {failed_seed}: {why}", soft_wrap=True, markup=False)
        reports.append(report)
    if markdown:
        markdown.parent.mkdir(parents=True, exist_ok=True)
        markdown.write_text(markdown_table(reports), encoding="utf-8")
    if as_json:
        print_json(
            [
                {
                    "task": r.task_id,
                    "episodes": r.episodes,
                    "successes": r.successes,
                    "success_rate": r.success_rate,
                    "failures": dict(r.failures),
                    "failed_seeds": r.failed_seeds,
                    "seconds": r.seconds,
                    "median_episode_s": r.median_seconds,
                    "stage_count": r.stage_count,
                    "stages": r.stages,
                    "mean_progress": r.mean_progress,
                    "expert_failures": {str(k): v for k, v in r.expert_failures.items()},
                    "failed_steps": dict(Counter(step_of(v) for v in r.expert_failures.values())),
                }
                for r in reports
            ]
        )
        return
    table = Table(title=f"scripted experts, {plural(episodes, 'seed')} from {seed}")
    for column in ("task", "success", "rate", "stages (progress)", "failures"):
        table.add_column(column, overflow="fold")  # ids are never cut
    for r in reports:
        failures = ", ".join(f"{k}: {v}" for k, v in r.failures.most_common()) or "-"
        stages = f"{r.stage_count} ({100 * r.mean_progress:.0f} %)" if r.stage_count else "-"
        table.add_row(r.task_id, f"{r.successes}/{r.episodes}", f"{100 * r.success_rate:.0f} %", stages, failures)
    out_console.print(table)
