"""``pipette new-task`` and ``pipette assets new``: author tasks and assets from descriptions."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.syntax import Syntax

from pipette_cli.cli import assets as assets_cli
from pipette_cli.cli.common import BACKEND_HELP, STATE, err_console, out_console, print_json, wrote_task_line
from pipette_cli.errors import plural
from pipette_cli.language.understanding import not_understood_line, refused_under_yes
from pipette_cli.registry import load_registry


def _confirm(question: str, yes: bool) -> bool:
    if yes:
        return True
    if not sys.stdin or not sys.stdin.isatty():
        try:
            answer = sys.stdin.readline() if sys.stdin else ""
        except (OSError, ValueError):
            answer = ""
        if not answer:
            err_console.print(
                f"{question} [y/N] no answer (stdin is not a terminal); pass --yes to write",
                markup=False,
                soft_wrap=True,
            )
            return False
        err_console.print(f"{question} [y/N] {answer.strip()}", markup=False, soft_wrap=True)
        return answer.strip().lower() in ("y", "yes")
    return typer.confirm(question, default=False, err=True)


def new_task(
    description: Annotated[str, typer.Argument(help="What the robot should do, in plain English.")],
    backend: Annotated[str, typer.Option("--backend", "-b", help=BACKEND_HELP)] = "offline",
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="File or folder to write (default: ./<name>.yaml).")
    ] = None,
    check: Annotated[
        bool,
        typer.Option(
            "--check", help="Gate: build, an idle rollout must fail, the expert must succeed on 4 of 5 seeds."
        ),
    ] = False,
    episodes: Annotated[
        int, typer.Option("--episodes", min=1, max=50, help="Seeds for --check (80 % must succeed).")
    ] = 5,
    yes: Annotated[bool, typer.Option("--yes", "-y", help="Write without asking.")] = False,
    task_id: Annotated[str | None, typer.Option("--id", help="Task id to use instead of the derived one.")] = None,
    namespace: Annotated[str, typer.Option("--namespace", help="Namespace of the derived id.")] = "generated",
    model: Annotated[
        str | None, typer.Option("--model", help="LLM model (else PIPETTE_LLM_MODEL / PIPETTE_OLLAMA_MODEL).")
    ] = None,
    base_url: Annotated[
        str | None, typer.Option("--base-url", help="LLM server URL (else PIPETTE_LLM_BASE_URL / OLLAMA_HOST).")
    ] = None,
    dry_run: Annotated[bool, typer.Option("--dry-run", help="Show the draft; write nothing.")] = False,
    force: Annotated[
        bool, typer.Option("--force", help="Write even if --check fails, and overwrite an existing file.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the draft, the plan and the check as JSON.")] = False,
) -> None:
    """Turn a description into a task: a typed plan (objects, steps) checked against the asset
    library and the robot's facts, a reachable layout, a success criterion per step (a sequence
    for several) with thresholds from the assets' geometry, and an expert skill program. Shows the
    YAML (fields to verify are marked VERIFY) and writes it after confirmation (or --yes).
    Requests that cannot be simulated are refused with the reason.

    Example: pipette new-task "Open the microfuge, put the 2 mL tube in, then close the lid" --check --out registry/generated/ --yes
    """
    # deferred: httpx, mink, scipy (~0.4 s)
    from pipette_cli.authoring.backends import make_backend
    from pipette_cli.authoring.workflow import check_gate, draft_task, plan_summary, write_task
    from pipette_cli.taskgen.plan import PlanError

    registry = load_registry(STATE.registry_dirs)
    engine = make_backend(backend, model=model, base_url=base_url)
    gate = check_gate(episodes, enforce=not force) if check else None
    if check:
        with err_console.status(f"drafting and checking ({plural(episodes, 'seed')})"):
            drafted = draft_task(
                description, engine, namespace=namespace, task_id=task_id, registry=registry, gate=gate
            )
    else:
        drafted = draft_task(description, engine, namespace=namespace, task_id=task_id, registry=registry)
    target = drafted.target_path(out)
    report = drafted.report
    if as_json:
        print_json(
            {
                "id": drafted.spec.id,
                "path": str(target),
                "plan": drafted.plan.model_dump(mode="json"),
                "steps": plan_summary(drafted.composed.checked),
                "remarks": drafted.remarks,
                "notes": drafted.notes,
                "not_understood": drafted.not_understood,
                "yaml": drafted.yaml_text,
                "check": report.as_dict() if report else None,
            }
        )
    else:
        if out_console.is_terminal:
            out_console.print(Syntax(drafted.yaml_text, "yaml", theme="ansi_dark", word_wrap=True))
        else:
            out_console.print(drafted.yaml_text, end="", markup=False, highlight=False)
        err_console.print(
            f"drafted {drafted.spec.id} ({plural(len(drafted.plan.steps), 'step')}, {drafted.spec.success.type}) "
            f"with the {engine.name} backend",
            markup=False,
            soft_wrap=True,
        )
    if report is not None:
        for problem in report.problems:
            err_console.print(f"check: {problem}", markup=False, soft_wrap=True)
        passed = report.ok and report.solve.status == "solved"
        err_console.print(
            f"check: {'ok' if passed else 'FAILED (written anyway: --force)'}; idle rollout "
            f"{plural(report.idle_steps, 'step')}, objects moved at most {report.max_drift_m * 1000:.1f} mm; "
            f"{report.solve.summary()} ({report.seconds:.1f} s)",
            markup=False,
            soft_wrap=True,
        )
    for note in drafted.notes:
        err_console.print(note, markup=False, soft_wrap=True)
    if drafted.not_understood:
        err_console.print(
            f"[yellow]{escape(not_understood_line(drafted.not_understood, 'draft'))}[/yellow]", soft_wrap=True
        )
    if dry_run:
        err_console.print("dry run: nothing written")
        return
    if drafted.not_understood and yes:
        raise PlanError(refused_under_yes(drafted.not_understood, "write"))
    if not _confirm(f"write {target}?", yes):
        err_console.print("not written")
        raise typer.Exit(1)
    path = write_task(drafted, target, force=force)
    err_console.print(wrote_task_line(path, drafted.spec.id, verify=True), markup=False, soft_wrap=True)


@assets_cli.app.command("new")
def new_asset(
    description: Annotated[str, typer.Argument(help="The asset in plain English, e.g. 'a 300 mL beaker'.")],
    backend: Annotated[str, typer.Option("--backend", "-b", help=BACKEND_HELP)] = "offline",
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="Asset root to write <category>/<id>.usda under (default: first PIPETTE_ASSET_PATH entry, else ./pipette_assets).",
        ),
    ] = None,
    asset_id: Annotated[
        str | None, typer.Option("--id", help="Asset id (default: derived from the generator and size).")
    ] = None,
    yes: Annotated[bool, typer.Option("--yes", "-y", help="Write without asking.")] = False,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
    model: Annotated[str | None, typer.Option("--model", help="LLM model for openai/ollama.")] = None,
    base_url: Annotated[str | None, typer.Option("--base-url", help="LLM server URL.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Make a new USD asset from a description: picks a parametric generator and its parameters
    (offline or with an LLM backend), writes the .usda and validates it (USD, compile, physics).

    Example: pipette assets new "a 300 mL Erlenmeyer flask" --out my_assets/ --yes
    """
    # deferred: pxr.Usd, httpx (~0.25 s)
    from pipette_cli.authoring.assets_new import default_asset_root, draft_asset, write_asset
    from pipette_cli.authoring.backends import make_backend
    from pipette_cli.taskgen.plan import PlanError

    engine = make_backend(backend, model=model, base_url=base_url)
    drafted = draft_asset(description, engine, asset_id=asset_id)
    root = out or default_asset_root()
    summary = drafted.summary()
    unread = not_understood_line(drafted.not_understood, "asset")
    if drafted.existing and not asset_id:
        if as_json:
            print_json({"existing": drafted.existing, **summary})
        err_console.print(
            f"the library already has this asset: {drafted.existing} "
            f"({drafted.spec.generator}, {drafted.spec.describe()}); pass --id to write a copy"
        )
        if unread:
            err_console.print(f"[yellow]{escape(unread)}[/yellow]", soft_wrap=True)
        return
    if not as_json:
        out_console.print(
            f"{drafted.asset_id}: {drafted.spec.generator} {drafted.spec.describe()} -> {root}/{drafted.category}/"
        )
    if unread:
        err_console.print(f"[yellow]{escape(unread)}[/yellow]", soft_wrap=True)
    if drafted.not_understood and yes:
        raise PlanError(refused_under_yes(drafted.not_understood, "write"))
    if not _confirm(f"write {drafted.asset_id} under {root}?", yes):
        err_console.print("not written")
        raise typer.Exit(1)
    report = write_asset(drafted, root, force=force)
    if as_json:
        print_json({**summary, "path": str(report.path), "validation": report.as_dict()})
    err_console.print(
        f"wrote {report.path} (validated before writing: USD, MuJoCo compile, physics); "
        f"use it with PIPETTE_ASSET_PATH={root}"
    )
