"""``pipette agent``: a request in words -> a checked plan of ``pipette`` commands, shown, then run."""

from __future__ import annotations

import shlex
import sys
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table

from pipette_cli.agent.answers import Answer, answer
from pipette_cli.agent.catalog import AgentError, CommandCatalog, cli_catalog, render_args, say_missing
from pipette_cli.agent.plan import CheckedPlan, Context, PlanSpec, StepRef, StepSpec, plain
from pipette_cli.agent.run import PlanRunner
from pipette_cli.cli.common import BACKEND_HELP, STATE, err_console, out_console, print_json
from pipette_cli.errors import PipetteError
from pipette_cli.language.understanding import not_understood_line, refused_under_yes
from pipette_cli.registry import load_registry


def make_agent(catalog: CommandCatalog, backend: str, model: str | None = None, base_url: str | None = None):
    """The offline parser, or an LLM agent on a server of the one backend registry
    (:func:`pipette_cli.llm.backend_names`, shared with ``new-task``)."""
    from pipette_cli.agent.offline import OfflineAgent  # deferred: the offline parser (~35 ms, 6 modules)
    from pipette_cli.llm import OFFLINE, check_backend

    registry = load_registry(STATE.registry_dirs)
    if check_backend(backend) == OFFLINE:
        return OfflineAgent(catalog, registry)
    from pipette_cli.agent.llm import LLMAgent  # deferred: httpx (~50 ms; only an LLM backend needs it)

    return LLMAgent(backend, catalog, registry, model=model, base_url=base_url)


def command_text(catalog: CommandCatalog, plan: CheckedPlan, index: int) -> str:
    """Step ``index`` (1-based) as a command line, earlier steps' outputs filled in."""
    step = plan.steps[index - 1]
    info = catalog.get(step.command)
    return shlex.join(["pipette", *info.path, *render_args(info, plan.resolved_args(step))])


def plan_json(plan: CheckedPlan, agent: Any) -> dict[str, Any]:
    steps = []
    reads_only = True
    for step in plan.steps:
        item: dict[str, Any] = {
            "step": step.index,
            "command": step.command,
            "args": {k: plain(v) for k, v in step.args.items()},
            "command_line": command_text(agent.catalog, plan, step.index),
            "missing": step.missing,
            "output": step.product,
            "notes": step.notes,
        }
        is_answer = agent.catalog.get(step.command).is_answer
        reads_only = reads_only and is_answer
        if is_answer and reads_only and not step.missing:
            found = answer(step.command, plan.resolved_args(step), agent.registry)
            item["answer"] = {"text": found.text, **found.data}
        steps.append(item)
    return {
        "request": plan.request,
        "backend": agent.name,
        "runnable": plan.runnable,
        "not_understood": plan.unused,
        "steps": steps,
    }


def show_plan(catalog: CommandCatalog, plan: CheckedPlan) -> None:
    table = Table(title="plan", title_justify="left", show_lines=False)
    for column in ("step", "command", "notes"):
        table.add_column(column, overflow="fold")
    for step in plan.steps:
        notes = [f"[red]needs {escape(say_missing(step.missing))}[/red]"] if step.missing else []
        refs = [r for v in step.args.values() for r in (v if isinstance(v, list) else [v]) if isinstance(r, StepRef)]
        notes += [f"input: output of step {r.from_step}" for r in refs]
        notes += [escape(n) for n in step.notes]
        table.add_row(str(step.index), escape(command_text(catalog, plan, step.index)), "\n".join(notes))
    out_console.print(table)


def show_not_understood(plan: CheckedPlan) -> None:
    line = not_understood_line(plan.unused)
    if line:
        err_console.print(f"[yellow]{escape(line)}[/yellow]", soft_wrap=True)


def show_answer(found: Answer) -> None:
    out_console.print(found.text, markup=False, highlight=False)
    if found.rows:
        table = Table(show_header=True)
        for column in found.columns:
            table.add_column(column, overflow="fold")  # ids are never cut
        for row in found.rows:
            table.add_row(*(escape(cell) for cell in row))
        out_console.print(table)


def _ask_missing(agent: Any, plan: CheckedPlan, context: Context) -> CheckedPlan:
    """Prompt for each missing value; a missing choice ("endpoint|policy") first asks which one."""
    steps = []
    for step in plan.steps:
        args: dict[str, Any] = {k: plain(v) for k, v in step.args.items()}
        for name in step.missing:
            options = name.split("|")
            while name not in options:
                name = typer.prompt(
                    f"step {step.index} ('pipette {step.command}') needs one of {', '.join(options)}; which"
                ).strip()
            args[name] = typer.prompt(f"step {step.index} {name.replace('_', ' ')}")
        steps.append(StepSpec(command=step.command, args=args))
    return agent.validator.check(PlanSpec(steps=steps), request=plan.request, context=context)


def _handle(
    agent: Any, request: str, context: Context, *, as_json: bool, yes: bool, interactive: bool, dry_run: bool = False
) -> None:
    plan = agent.plan(request, context)
    if dry_run:  # the plan as it stands, missing values named in it; nothing asked, nothing run
        context.remember(plan)
        if as_json:
            print_json({**plan_json(plan, agent), "dry_run": True})
            return
        show_plan(agent.catalog, plan)
        show_not_understood(plan)
        steps = f"{len(plan.steps)} step{'s' if len(plan.steps) != 1 else ''}"
        err_console.print(f"dry run: {steps} planned, nothing run", soft_wrap=True)
        return
    can_ask = interactive or (sys.stdin.isatty() and not yes)
    if plan.missing and not as_json:
        if not can_ask:
            needs = "; ".join(
                f"step {i} (pipette {plan.steps[i - 1].command}) needs {say_missing(m)}"
                for i, m in plan.missing.items()
            )
            count = sum(len(m) for m in plan.missing.values())
            raise AgentError(f"{needs}; add {'it' if count == 1 else 'them'} to the request")
        show_plan(agent.catalog, plan)
        for _ in range(3):  # answers can reveal more (a task gives a default output; a bad value is re-asked)
            plan = _ask_missing(agent, plan, context)
            if not plan.missing:
                break
    context.remember(plan)
    if as_json:
        print_json(plan_json(plan, agent))
        if not (yes and plan.runnable and not plan.unused):
            return
    catalog = agent.catalog
    answers_only = all(catalog.get(s.command).is_answer for s in plan.steps)
    if not as_json and not answers_only:
        show_plan(agent.catalog, plan)
    if not as_json:
        show_not_understood(plan)
    if plan.unused and not answers_only and yes:
        raise AgentError(refused_under_yes(plan.unused, "run"))
    if not answers_only and not yes:
        if not (interactive or sys.stdin.isatty()):
            err_console.print(f"[dim]add --yes to run {'it' if len(plan.steps) == 1 else 'them'}[/dim]")
            return
        if not typer.confirm(
            f"Run {'it' if len(plan.steps) == 1 else f'these {len(plan.steps)} steps'}?", default=False, err=True
        ):
            return
    global_args = [arg for d in STATE.registry_dirs for arg in ("--registry-dir", str(d))]
    runner = PlanRunner(
        catalog,
        err_console,
        global_args=global_args,
        show_output=lambda text: out_console.print(text, end="", markup=False, highlight=False),
        show_answer=show_answer,
        background=agent.vocab.background,
        registry=agent.registry,
    )
    runner.run(plan)


def agent(
    ctx: typer.Context,
    request: Annotated[str | None, typer.Argument(help="What you want done, in words.")] = None,
    backend: Annotated[str, typer.Option("--backend", "-b", help=BACKEND_HELP)] = "offline",
    yes: Annotated[bool, typer.Option("--yes", "-y", help="Run the plan without asking.")] = False,
    as_json: Annotated[
        bool, typer.Option("--json", help="Print the plan (and answers) as JSON; run it only with --yes.")
    ] = False,
    interactive: Annotated[bool, typer.Option("--interactive", "-i", help="A small REPL that keeps context.")] = False,
    dry_run: Annotated[
        bool, typer.Option("--dry-run", help="Show the plan (missing values included); ask nothing, run nothing.")
    ] = False,
    model: Annotated[str | None, typer.Option("--model", help="LLM model for openai/ollama.")] = None,
    base_url: Annotated[str | None, typer.Option("--base-url", help="LLM server URL.")] = None,
) -> None:
    """Turn a request into a plan of `pipette` commands, show it as a table, and run it step by
    step after confirmation (or --yes); questions about tasks, demos and scores are answered.
    With --dry-run the plan is only shown (as with `new-task --dry-run`, nothing is done).

    Example: pipette agent "record 20 demos of the test tube task, augment them, convert and train ACT"
    """
    agent_impl = make_agent(cli_catalog(ctx.find_root().command), backend, model, base_url)
    context = Context()
    if not interactive:
        if not request:
            raise AgentError("give a request, or --interactive")
        _handle(agent_impl, request, context, as_json=as_json, yes=yes, interactive=False, dry_run=dry_run)
        return
    err_console.print("pipette agent — say what to do; 'quit' ends. It remembers the last task and outputs.")
    while True:
        try:
            line = input("agent> ").strip()
        except EOFError:
            break
        if line.lower() in ("quit", "exit", "q"):
            break
        if not line:
            continue
        try:
            _handle(agent_impl, line, context, as_json=as_json, yes=yes, interactive=True, dry_run=dry_run)
        except PipetteError as exc:
            err_console.print(f"[red]error:[/red] {escape(str(exc))}")
