"""``pipette agent``: turn a request into the right ``pipette`` command, show it, run it."""

from __future__ import annotations

import shlex
import subprocess
import sys
from typing import Annotated, Any

import typer
from rich.markup import escape

from pipette_cli.agent.catalog import AgentError, load_catalog, say_missing
from pipette_cli.agent.offline import Context, OfflineAgent
from pipette_cli.agent.plan import CommandPlanSpec
from pipette_cli.cli.common import STATE, err_console, out_console, print_json
from pipette_cli.registry import load_registry


def make_agent(backend: str, model: str | None = None, base_url: str | None = None):
    catalog, registry = load_catalog(), load_registry(STATE.registry_dirs)
    if backend == "offline":
        return OfflineAgent(catalog, registry)
    from pipette_cli.agent.llm import LLMAgent

    return LLMAgent(backend, catalog, registry, model=model, base_url=base_url)


def command_line(plan: CommandPlanSpec) -> list[str]:
    return ["pipette", *load_catalog().argv(plan.command, dict(plan.params))]


def _ask_missing(plan: CommandPlanSpec) -> CommandPlanSpec:
    """Prompt for each missing value; a missing choice ("endpoint|policy") first asks which one."""
    params: dict[str, Any] = dict(plan.params)
    for name in plan.missing:
        options = name.split("|")
        while name not in options:
            name = typer.prompt(f"'pipette {plan.command}' needs one of {', '.join(options)}; which").strip()
        params[name] = typer.prompt(f"{name.replace('_', ' ')}")
    return plan.model_copy(update={"params": params, "missing": []})


def _handle(agent, request: str, context: Context, *, as_json: bool, yes: bool, interactive: bool) -> int:
    plan = agent.plan(request, context)
    if plan.missing and as_json:
        print_json({"command": plan.command, "params": plan.params, "missing": plan.missing, "notes": plan.notes})
        return 0
    if plan.missing:
        if not sys.stdin.isatty() and not interactive:
            raise AgentError(f"'pipette {plan.command}' needs {say_missing(plan.missing)}; add them to the request")
        plan = _ask_missing(plan)
    argv = command_line(plan)
    context.history.append(plan)
    if as_json:
        print_json({"command": shlex.join(argv), "argv": argv, "params": plan.params, "missing": [], "notes": plan.notes})
    else:
        for note in plan.notes:
            err_console.print(f"[dim]{escape(note)}[/dim]")
        out_console.print(shlex.join(argv), markup=False, highlight=False)
    if not yes and (as_json or not typer.confirm("Run it?", default=False, err=True)):
        return 0
    # the CLI itself, never a shell: argv comes from the catalog
    return subprocess.call([sys.executable, "-m", "pipette_cli.cli.main", *argv[1:]])


def agent(
    request: Annotated[str | None, typer.Argument(help="What you want done, in words.")] = None,
    backend: Annotated[str, typer.Option("--backend", "-b", help="offline, openai or ollama.")] = "offline",
    yes: Annotated[bool, typer.Option("--yes", "-y", help="Run without asking.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the plan (or the missing fields) as JSON.")] = False,
    interactive: Annotated[bool, typer.Option("--interactive", "-i", help="A small REPL that keeps context.")] = False,
    model: Annotated[str | None, typer.Option("--model", help="LLM model for openai/ollama.")] = None,
    base_url: Annotated[str | None, typer.Option("--base-url", help="LLM server URL.")] = None,
) -> None:
    """Turn a request into the exact `pipette` command, print it and run it after confirmation.

    Example: pipette agent "collect 20 demos of the test tube task with 64 pixel images"
    """
    agent_impl = make_agent(backend, model, base_url)
    context = Context()
    if not interactive:
        if not request:
            raise AgentError("give a request, or --interactive")
        code = _handle(agent_impl, request, context, as_json=as_json, yes=yes, interactive=False)
        raise typer.Exit(code)
    err_console.print("pipette agent — say what to do; 'quit' ends. It remembers the last task and file.")
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
            _handle(agent_impl, line, context, as_json=as_json, yes=yes, interactive=True)
        except AgentError as exc:
            err_console.print(f"[red]error:[/red] {escape(str(exc))}")
