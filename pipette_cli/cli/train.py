"""``pipette train``: LeRobot training (``lerobot-train``) per task with the paper's defaults."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from pipette_cli.cli.common import STATE, BarOrLines, err_console, out_console, print_json, spec_default, spec_help
from pipette_cli.errors import DatasetError, plural
from pipette_cli.lerobot.convert import DatasetVersion
from pipette_cli.lerobot.train import (
    IfExists,
    Policy,
    TrainError,
    TrainOptions,
    cpu_warning,
    job_steps,
    lerobot_train_executable,
    missing_datasets,
    plan,
    resolve_tasks,
    run_job,
    torchvision_weights,
)
from pipette_cli.registry import load_registry


def train(
    tasks: Annotated[
        str, typer.Option("--tasks", help="Comma-separated task ids, or `all` (every registered task with a dataset).")
    ],
    policy: Annotated[Policy, typer.Option("--policy", help="act, smolvla or pi0.")],
    dataset_version: Annotated[
        str, typer.Option("--dataset-version", help=spec_help(TrainOptions, "dataset_version"))
    ] = spec_default(TrainOptions, "dataset_version").value,
    steps: Annotated[int | None, typer.Option("--steps", min=1, help=spec_help(TrainOptions, "steps"))] = spec_default(
        TrainOptions, "steps"
    ),
    batch_size: Annotated[
        int | None, typer.Option("--batch-size", min=1, help=spec_help(TrainOptions, "batch_size"))
    ] = spec_default(TrainOptions, "batch_size"),
    device: Annotated[str | None, typer.Option("--device", help=spec_help(TrainOptions, "device"))] = spec_default(
        TrainOptions, "device"
    ),
    datasets_root: Annotated[
        Path, typer.Option("--datasets-root", help=spec_help(TrainOptions, "datasets_root"))
    ] = spec_default(TrainOptions, "datasets_root"),
    output_root: Annotated[
        Path, typer.Option("--output-root", help=spec_help(TrainOptions, "output_root"))
    ] = spec_default(TrainOptions, "output_root"),
    if_exists: Annotated[
        IfExists, typer.Option("--if-exists", help=spec_help(TrainOptions, "if_exists"))
    ] = spec_default(TrainOptions, "if_exists"),
    pretrained_path: Annotated[
        str | None, typer.Option("--pretrained-path", help=spec_help(TrainOptions, "pretrained_path"))
    ] = spec_default(TrainOptions, "pretrained_path"),
    vlm_path: Annotated[
        str | None, typer.Option("--vlm-path", help=spec_help(TrainOptions, "vlm_path"))
    ] = spec_default(TrainOptions, "vlm_path"),
    act_backbone_weights: Annotated[
        str | None,
        typer.Option(
            "--act-backbone-weights",
            parser=torchvision_weights,
            help=spec_help(TrainOptions, "act_backbone_weights"),
        ),
    ] = spec_default(TrainOptions, "act_backbone_weights"),
    offline: Annotated[bool, typer.Option("--offline", help=spec_help(TrainOptions, "offline"))] = spec_default(
        TrainOptions, "offline"
    ),
    threads: Annotated[
        int | None, typer.Option("--threads", min=1, help=spec_help(TrainOptions, "threads"))
    ] = spec_default(TrainOptions, "threads"),
    extra: Annotated[
        list[str] | None,
        typer.Option(
            "--extra",
            help="One more lerobot-train flag, e.g. --extra=--policy.dim_model=64 (repeatable; wins over the defaults).",
        ),
    ] = None,
    dry_run: Annotated[bool, typer.Option("--dry-run", help="Print each task's full command and exit.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable plan/result.")] = False,
) -> None:
    """Train a policy on each task's LeRobot dataset with `lerobot-train`, one run after another.

    Datasets come from datasets/<task>/<version> (as written by `pipette convert`); a missing one
    stops everything before any run (with --dry-run it is only a warning). Each run writes
    outputs/train/<policy>/<task>_<version>/ and tees its output to
    outputs/train/<policy>/<task>_<version>.log. Nothing is pushed to the Hub.

    Example: pipette train --tasks PickUpTestTube,OpenCentrifugeLid --policy act --dataset-version raw --dry-run
    """
    try:
        version = DatasetVersion(dataset_version)
    except ValueError:
        raise DatasetError(f"--dataset-version must be raw or augmented, not {dataset_version!r}") from None
    requested = [t.strip() for t in tasks.split(",") if t.strip()]
    if not requested:
        raise TrainError("--tasks is empty: give task ids separated by commas, or all")
    registry = load_registry(STATE.registry_dirs)
    task_ids = resolve_tasks(
        requested, registry.ids(), lambda t: registry.entry(t).spec.id, version, datasets_root, allow_missing=dry_run
    )
    options = TrainOptions(
        policy=policy,
        dataset_version=version,
        steps=steps,
        batch_size=batch_size,
        device=device,
        datasets_root=datasets_root,
        output_root=output_root,
        if_exists=if_exists,
        pretrained_path=pretrained_path,
        vlm_path=vlm_path,
        act_backbone_weights=act_backbone_weights,
        offline=offline,
        threads=threads,
        extra=tuple(extra or ()),
    )
    executable = "lerobot-train" if dry_run else lerobot_train_executable()
    jobs = plan(task_ids, options, executable=executable)
    slow = cpu_warning(options, [j for j in jobs if j.action != "skip"])
    if slow:
        err_console.print(f"[yellow]warning:[/yellow] {escape(slow)}", soft_wrap=True)
    if dry_run:
        for root in missing_datasets(task_ids, version, datasets_root):
            err_console.print(
                f"[yellow]warning:[/yellow] no LeRobot dataset (meta/info.json) at {escape(str(root))} "
                f"yet; make it with `pipette convert ... --dataset-version {version.value}` before training",
                soft_wrap=True,
            )
        if as_json:
            print_json(
                [
                    {
                        "task": j.task_id,
                        "action": j.action,
                        "argv": list(j.argv),
                        "env": j.env,
                        "output_dir": str(j.output_dir),
                        "log": str(j.log_file),
                    }
                    for j in jobs
                ]
            )
            return
        for job in jobs:
            if job.action == "skip":
                out_console.print(f"# {job.task_id}: skip ({job.output_dir} exists; --if-exists overwrite|continue)")
                continue
            env = " ".join(f"{k}={v}" for k, v in job.env.items())
            note = " (delete it first)" if job.action == "overwrite" else ""
            out_console.print(f"# {job.task_id}: {job.action}{note} -> {job.output_dir}, log {job.log_file}")
            out_console.print((env + " " if env else "") + shlex.join(job.argv), markup=False)
        return
    results = []
    echo = None if STATE.verbosity < 0 or as_json else sys.stderr
    for i, job in enumerate(jobs, 1):
        if job.action == "skip":
            err_console.print(
                f"[{i}/{len(jobs)}] {job.task_id}: skipped, {job.output_dir} exists (--if-exists overwrite|continue)",
                markup=False,
            )
        else:
            err_console.print(
                f"[{i}/{len(jobs)}] {job.task_id}: {job.action} -> {job.output_dir} (log {job.log_file})", markup=False
            )
        if job.action == "skip":
            results.append(run_job(job))
            continue
        # lerobot-train's own lines are echoed; without a terminal a line every few seconds adds the
        # step, rate and time left, and shows the run is alive while it loads
        with BarOrLines(f"train {job.task_id}", "steps", bar=False) as progress:
            progress.start(job_steps(job), done=0 if job.action != "continue" else None)
            results.append(run_job(job, echo=echo, on_step=progress.update))
    report = [
        {
            "task": r.task_id,
            "action": r.action,
            "returncode": r.returncode,
            "seconds": round(r.seconds, 1),
            "checkpoint": str(r.checkpoint) if r.checkpoint else None,
        }
        for r in results
    ]
    if as_json:
        print_json(report)
    else:
        for r in results:
            state = "skipped" if r.action == "skip" else "ok" if r.returncode == 0 else f"failed (exit {r.returncode})"
            out_console.print(
                f"{r.task_id}: {state}, {r.seconds:.1f} s" + (f", {r.checkpoint}" if r.checkpoint else ""), markup=False
            )
    failed = [r for r in results if r.returncode != 0]
    if failed:
        logs = ", ".join(str(j.log_file) for j in jobs if j.task_id in {r.task_id for r in failed})
        raise TrainError(f"{len(failed)} of {plural(len(results), 'training run')} failed; see {logs}")
