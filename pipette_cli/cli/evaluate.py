"""``pipette eval TASK``: closed-loop evaluation of a policy; ``pipette eval report DIR...``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import click
import typer
from typer.core import TyperCommand

from pipette_cli.cli.common import RobotOption, err_console, load_task, out_console, print_json
from pipette_cli.errors import PipetteError


class EvalCommand(TyperCommand):
    """``pipette eval TASK ...``, except that ``pipette eval report ...`` is handed whole to the
    ``report`` command, so that ``pipette eval report --help`` is the report's help."""

    @property
    def subcommands(self) -> dict[str, click.Command]:
        """Commands reached through this one's first argument (the agent's catalog lists them)."""
        return {"report": _report_click()}

    def make_context(self, info_name: str | None, args: list[str], parent: click.Context | None = None,
                     **extra: Any) -> click.Context:
        if args[:1] == ["report"]:
            return _report_click().make_context(f"{info_name} report", args[1:], parent=parent, **extra)
        return super().make_context(info_name, args, parent=parent, **extra)


def _report_click() -> click.Command:
    report_app = typer.Typer(add_completion=False)
    report_app.command("report")(report_command)
    return typer.main.get_command(report_app)


def eval_command(
    task_id: Annotated[str, typer.Argument(help="Task id (or `report`: see `pipette eval report --help`).")],
    endpoint: Annotated[str | None, typer.Option("--endpoint", help="Policy server (pipette serve), e.g. tcp://127.0.0.1:5555.")] = None,
    policy: Annotated[Path | None, typer.Option("--policy", help="Or: a policy folder evaluated in this process (no server).")] = None,
    policy_type: Annotated[str | None, typer.Option(
        "--policy-type", help="act, smolvla or pi0: decoding, timeouts, gripper thresholds "
                              "(default: the `type` in --policy's config.json, else act).")] = None,
    episodes: Annotated[int, typer.Option("--episodes", "-n", min=1, help="Episodes (seeds seed..seed+n-1).")] = 100,
    seed: Annotated[int, typer.Option("--seed", help="First episode seed.")] = 0,
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Folder for episode_XXXX.json and summary.json.")] = None,
    dataset_version: Annotated[str, typer.Option("--dataset-version", help="raw or augmented: the label `eval report` groups by.")] = "raw",
    image_size: Annotated[int | None, typer.Option("--image-size", help="Camera image side (must match the policy's).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    robot: RobotOption = None,
) -> None:
    """Evaluate a policy on a task (30 Hz control, 10 Hz queries; paper A.4/A.6).

    The decoding follows --policy-type, or the `type` LeRobot wrote into --policy's config.json.
    `pipette eval report DIR...` tabulates results (see `pipette eval report --help`).

    Example: pipette eval PickUpTestTube --endpoint tcp://127.0.0.1:5555 --episodes 100 --out evals/act_raw
    """
    if (endpoint is None) == (policy is None):
        raise PipetteError("give exactly one of --endpoint (a running `pipette serve`) and --policy (in-process)")
    if dataset_version not in ("raw", "augmented"):
        raise PipetteError(f"--dataset-version must be raw or augmented, not {dataset_version!r}")
    import json

    from pipette_cli.lerobot.evaluate import DecodeConfig, InProcessSource, evaluate, resolve_policy_type

    task = load_task(task_id, robot)
    config = DecodeConfig.for_policy(resolve_policy_type(policy_type, policy))
    if endpoint is not None:
        from pipette_cli.lerobot.client import PolicyClient

        source = PolicyClient(endpoint, timeout_ms=config.timeout_ms)
    else:
        source = InProcessSource(policy)  # type: ignore[arg-type]

    def progress(log) -> None:  # noqa: ANN001
        err_console.print(f"episode {log.episode}: {'success' if log.success else log.failure_reason} "
                          f"({log.control_steps} steps, {log.policy_queries} queries, {log.runtime_s:.1f} s)")

    summary = evaluate(task, source, config, episodes=episodes, seed=seed, out=out, image_size=image_size, on_episode=progress)
    summary["dataset_version"] = dataset_version
    if out is not None:
        (out / "summary.json").write_text(json.dumps(summary, indent=2))
    if as_json:
        print_json(summary)
    else:
        out_console.print(f"{task.id}: SR = {summary['successes']}/{summary['episodes']} = {100 * summary['success_rate']:.1f} %")


def report_command(
    folders: Annotated[list[Path], typer.Argument(help="Folders holding summary.json files (searched recursively).")],
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Also write OUT.md, OUT.csv and a bar chart OUT.png.")] = None,
) -> None:
    """Tabulate evaluation results: one row per (task, policy), one column per dataset version.

    Example: pipette eval report evals/ --out docs/results
    """
    from pipette_cli.lerobot.report import bar_chart, csv_text, load_summaries, markdown

    rows = load_summaries(folders)
    text = markdown(rows)
    out_console.print(text, markup=False, highlight=False, end="")
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.with_suffix(".md").write_text(text)
        out.with_suffix(".csv").write_text(csv_text(rows))
        bar_chart(rows, out.with_suffix(".png"))
        err_console.print(f"wrote {out.with_suffix('.md')}, .csv and .png")
