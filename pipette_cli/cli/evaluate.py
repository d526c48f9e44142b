"""``pipette eval [TASK] [--suite ID]``: closed-loop evaluation of a policy; ``pipette eval report DIR...``."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Annotated, Any

import typer
from typer.core import TyperCommand

from pipette_cli.cli.common import (
    STATE,
    RobotOption,
    err_console,
    out_console,
    policy_folder_of,
    print_json,
    show_progress,
    spec_default,
    spec_help,
)
from pipette_cli.demos.check import placed_on
from pipette_cli.demos.collect import deferred_interrupt
from pipette_cli.errors import PipetteError, plural
from pipette_cli.evaluation.settings import (
    ADHOC_EPISODES,
    ADHOC_SEED,
    POLICY_TYPES,
    DecodeConfig,
    EvalSettings,
    checkpoint_images,
    image_size_problem,
    resolve_policy_type,
)
from pipette_cli.evaluation.suites import adhoc_plan, episode_plan, load_suites
from pipette_cli.registry import load_registry
from pipette_cli.serving.protocol import DEFAULT_DEAD_AFTER_S, DEFAULT_DEVICE


class EvalCommand(TyperCommand):
    """``pipette eval TASK ...``, except that ``pipette eval report ...`` is handed whole to the
    ``report`` command, so that ``pipette eval report --help`` is the report's help."""

    # click types are typer's vendored click here (typer >= 0.29); annotated loosely for that reason
    @property
    def subcommands(self) -> dict[str, Any]:
        """Commands reached through this one's first argument (the agent's catalog lists them)."""
        return {"report": _report_click()}

    def make_context(self, info_name: str | None, args: list[str], parent: Any = None, **extra: Any) -> Any:
        if args[:1] == ["report"]:
            return _report_click().make_context(f"{info_name} report", args[1:], parent=parent, **extra)
        return super().make_context(info_name, args, parent=parent, **extra)


def _report_click() -> Any:
    report_app = typer.Typer(add_completion=False)
    report_app.command("report")(report_command)
    return typer.main.get_command(report_app)


def eval_command(
    task_id: Annotated[
        str | None,
        typer.Argument(
            help="Task id; with --suite, one task of the suite (default: all of them). `report`: see `pipette eval report --help`."
        ),
    ] = None,
    suite_id: Annotated[
        str | None,
        typer.Option(
            "--suite",
            help="A frozen evaluation suite (registry/suites/): its seeds, instructions, image size and render profile.",
        ),
    ] = None,
    endpoint: Annotated[
        list[str] | None,
        typer.Option(
            "--endpoint",
            help="Policy server (pipette serve), e.g. tcp://127.0.0.1:5555; repeat for several (worker i uses the i-th).",
        ),
    ] = None,
    policy: Annotated[
        Path | None,
        typer.Option(
            "--policy",
            help="Or: a policy evaluated in this process (no server): its pretrained_model folder, or a training "
            "run folder (its last checkpoint).",
        ),
    ] = None,
    policy_type: Annotated[
        str | None,
        typer.Option(
            "--policy-type",
            help=f"{', '.join(POLICY_TYPES[:-1])} or {POLICY_TYPES[-1]}: decoding, timeouts, gripper thresholds "
            "(paper A.4/A.6; default: the `type` in --policy's config.json, "
            f"else {spec_default(DecodeConfig, 'policy_type')}).",
        ),
    ] = None,
    episodes: Annotated[
        int | None,
        typer.Option(
            "--episodes",
            "-n",
            min=1,
            help=f"Episodes without a suite (seeds seed..seed+n-1; default {ADHOC_EPISODES}, as in the paper).",
        ),
    ] = None,
    seed: Annotated[
        int | None, typer.Option("--seed", help=f"First episode seed without a suite (default {ADHOC_SEED}).")
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out", "-o", help="Results folder; rerunning the command resumes it (suites: one subfolder per task)."
        ),
    ] = None,
    dataset_version: Annotated[
        str, typer.Option("--dataset-version", help=spec_help(EvalSettings, "dataset_version"))
    ] = spec_default(EvalSettings, "dataset_version"),
    image_size: Annotated[
        int | None, typer.Option("--image-size", help=spec_help(EvalSettings, "image_size"))
    ] = spec_default(EvalSettings, "image_size"),
    workers: Annotated[
        int,
        typer.Option(
            "--workers", "-w", min=1, help="Processes playing episodes (each loads the policy or connects to a server)."
        ),
    ] = 1,
    device: Annotated[
        str, typer.Option("--device", help="Torch device for --policy: cpu, cuda[:N] or auto (cuda when available).")
    ] = DEFAULT_DEVICE,
    dead_after: Annotated[
        float, typer.Option("--dead-after", min=0.1, help="Seconds a server may be unreachable before the run stops.")
    ] = DEFAULT_DEAD_AFTER_S,
    connect_timeout: Annotated[
        float, typer.Option("--connect-timeout", min=0.1, help="Seconds to wait for the server at the start.")
    ] = 30.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summaries as JSON.")] = False,
    robot: RobotOption = None,
) -> None:
    """Evaluate a policy on a task or a suite (30 Hz control, 10 Hz queries; paper A.4/A.6).

    Episode logs are written as they finish; rerunning the same command resumes after the last
    finished episode. A dead or unreachable server stops the run within seconds (safe hold, partial
    summary). `pipette eval report DIR...` tabulates results (see `pipette eval report --help`).

    Example: pipette eval --suite pipette/PaperBenchmark-v1 --endpoint tcp://127.0.0.1:5555 --out evals/act_raw
    """
    if dataset_version not in ("raw", "augmented"):
        raise PipetteError(f"--dataset-version must be raw or augmented, not {dataset_version!r}")
    from pipette_cli.evaluation.runner import PolicySource, check_servers  # deferred: zmq, scipy (~0.9 s)

    policy = policy_folder_of(policy) if policy is not None else None
    source = PolicySource(checkpoint=policy, endpoints=tuple(endpoint or ()), device=device, dead_after_s=dead_after)
    registry = load_registry(STATE.registry_dirs)
    config = DecodeConfig.for_policy(resolve_policy_type(policy_type, policy))
    temporary = tempfile.TemporaryDirectory(prefix="pipette-eval-") if out is None else None
    folder = out if out is not None else Path(temporary.name)  # type: ignore[union-attr]
    try:
        runs, settings = _plan(
            registry, task_id, suite_id, episodes, seed, image_size, folder, config, dataset_version, robot
        )
        cameras, size = runs[0].task.cameras, settings.image_size
        rendered = (size, size) if size else (cameras.height, cameras.width)
        if source.endpoints:
            check_servers(source.endpoints, rendered, connect_timeout)
        elif policy is not None:  # the same check as a server's, read off the checkpoint's config.json
            fix = "--image-size, or the suite's image_size"
            problem = image_size_problem(checkpoint_images(policy), rendered, f"in {policy}", fix)
            if problem is not None:
                raise PipetteError(problem)
        summaries = _run(runs, source, settings, workers)
    finally:
        if temporary is not None:
            temporary.cleanup()
    if as_json:
        print_json(summaries[0] if suite_id is None else {"suite": settings.suite, "summaries": summaries})
        return
    for s in summaries:
        low, high = s["success_ci95"]
        staged = f", stage progress {s['mean_progress']:.2f}" if s.get("mean_progress") is not None else ""
        out_console.print(
            f"{s['task']}: SR = {s['successes']}/{s['episodes']} = {100 * s['success_rate']:.1f} % "
            f"(95 % CI {100 * low:.1f}-{100 * high:.1f}){staged}"
        )


def _plan(
    registry: Any,
    task_id: str | None,
    suite_id: str | None,
    episodes: int | None,
    seed: int | None,
    image_size: int | None,
    out: Path,
    config: Any,
    dataset_version: str,
    robot: str | None = None,
) -> tuple[list[Any], Any]:
    """The task runs and settings of a suite (a folder per task) or of one task (``out`` itself),
    each task placed on ``robot`` when one is given."""
    from pipette_cli.evaluation.runner import TaskRun  # deferred: zmq, scipy (~0.9 s)

    if suite_id is None:
        if task_id is None:
            raise PipetteError("name a task or a suite: pipette eval TASK ... or pipette eval --suite ID ...")
        task = placed_on(registry.get(task_id), robot)
        plan = adhoc_plan(task, ADHOC_EPISODES if episodes is None else episodes, ADHOC_SEED if seed is None else seed)
        return [TaskRun(task, out, tuple(plan))], EvalSettings(config, image_size, dataset_version=dataset_version)
    fixed = [
        flag
        for flag, value in (("--episodes", episodes), ("--seed", seed), ("--image-size", image_size))
        if value is not None
    ]
    if fixed:
        raise PipetteError(
            f"{', '.join(fixed)}: the suite fixes seeds and image size; drop them or evaluate without --suite"
        )
    suite = load_suites(registry, STATE.registry_dirs).get(suite_id)
    tasks = None if task_id is None else [registry.get(task_id).id]
    by_task = episode_plan(suite.spec, tasks)
    runs = [
        TaskRun(placed_on(registry.get(t), robot), out / t.replace("/", "_"), tuple(eps)) for t, eps in by_task.items()
    ]
    settings = EvalSettings(config, suite.spec.image_size, suite.spec.render_profile, dataset_version, suite.record())
    return runs, settings


def _run(runs: list[Any], source: Any, settings: Any, workers: int) -> list[dict[str, Any]]:
    """Play the runs with a progress bar; the summaries, in run order."""
    from pipette_cli.evaluation.runner import evaluate_runs  # deferred: zmq, scipy (~0.9 s)

    ok = failed = 0
    progress = show_progress("eval", "episodes")

    def started(done: int, todo: int) -> None:
        if done:
            err_console.print(f"{plural(done, 'episode')} already logged; {todo} to go", soft_wrap=True)
        if todo:
            progress.start(todo)

    def finished(log: Any) -> None:
        nonlocal ok, failed
        ok, failed = ok + log.success, failed + (not log.success)
        if STATE.verbosity > 0:
            progress.print(
                f"{log.task} episode {log.episode}: {'success' if log.success else log.failure_reason} "
                f"({plural(log.control_steps, 'step')}, {plural(log.policy_queries, 'query', 'queries')}, {log.runtime_s:.1f} s)"
            )
        progress.update(advance=1, note=f"[green]{ok} ok[/green] [red]{failed} failed[/red]")

    try:
        with deferred_interrupt() as interrupted:
            result = evaluate_runs(
                runs, source, settings, workers=workers, on_start=started, on_episode=finished, stop=interrupted
            )
    finally:
        progress.stop()
    summaries = [result.summaries[run.task.id] for run in runs if run.task.id in result.summaries]
    if result.interrupted:
        err_console.print(
            f"interrupted after {result.new_episodes} new episodes; summaries written; "
            "run the same command again to resume",
            soft_wrap=True,
        )
        raise typer.Exit(interrupted.exit_code)
    return summaries


def report_command(
    folders: Annotated[list[Path], typer.Argument(help="Folders holding evaluation results (searched recursively).")],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Also write OUT.md, OUT.json, OUT.csv and a bar chart OUT.png.")
    ] = None,
) -> None:
    """Tabulate evaluation results: one row per (task, policy), raw and augmented side by side,
    with 95 % Wilson intervals, stage progress and an exact test of each difference.

    Reads episode logs (so a run without summary.json, or one cut short, still counts), else
    summary.json. Same episodes on both sides are compared pairwise (McNemar), others with Fisher.

    Example: pipette eval report evals/ --out docs/results
    """
    # deferred: scipy, PIL (~0.8 s)
    from pipette_cli.evaluation.report import build_report, load_runs, markdown, write_report

    report = build_report(load_runs(folders))
    out_console.print(markdown(report), markup=False, highlight=False, end="")
    if out is not None:
        paths = write_report(report, out)
        err_console.print(f"wrote {', '.join(str(p) for p in paths)}", soft_wrap=True)
