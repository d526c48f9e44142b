"""Entry point of the ``pipette`` console script.

Exit codes: 0 success, 1 a :class:`~pipette_cli.errors.PipetteError` (one line on stderr,
traceback only with ``--debug``), 2 usage errors (typer/click), 3 an evaluation stopped by a lost
policy server (partial summary written), 130 interrupted by Ctrl-C, 143 stopped by SIGTERM (both
after writing what finished, where the command can resume).
"""

from __future__ import annotations

import logging
import os
import re
import shlex
import sys
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Annotated, Any

# Offscreen rendering on a headless Linux machine needs EGL (MuJoCo's default, GLFW, needs a
# display); MuJoCo reads this when it is first imported, so it is set before anything imports it.
if sys.platform.startswith("linux") and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

import typer
from rich.logging import RichHandler
from rich.markup import escape

from pipette_cli import __version__
from pipette_cli.agent.catalog import CommandCatalog, cli_catalog
from pipette_cli.cli import agent as agent_cli
from pipette_cli.cli import assets as assets_cli
from pipette_cli.cli import augment as augment_cli
from pipette_cli.cli import authoring as authoring_cli  # also adds `assets new`
from pipette_cli.cli import collect as collect_cli
from pipette_cli.cli import convert as convert_cli  # also adds `data stats`
from pipette_cli.cli import data as data_cli
from pipette_cli.cli import demo as demo_cli
from pipette_cli.cli import evaluate as evaluate_cli
from pipette_cli.cli import experts as experts_cli
from pipette_cli.cli import serve as serve_cli
from pipette_cli.cli import sim as sim_cli
from pipette_cli.cli import tasks as tasks_cli
from pipette_cli.cli import train as train_cli
from pipette_cli.cli.common import STATE, err_console
from pipette_cli.errors import PipetteError

app = typer.Typer(
    name="pipette",
    help="Pipette: train robots for biomedical wet labs in MuJoCo.\n\nExample: pipette tasks list",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
START, PIPELINE, LOOK = "Start here", "The pipeline, step by step", "Tasks, assets, data and the simulator"
"""The panels of `pipette --help`, in the order a newcomer meets them."""


def _short(command: Callable[..., Any]) -> str:
    """A command's first sentence on one line (its help keeps the rest)."""
    text = " ".join((command.__doc__ or "").split("\n\n", 1)[0].split())
    return re.split(r"(?<=\.)\s", text, maxsplit=1)[0].rstrip(".")


for name, command, panel in (
    ("demo", demo_cli.demo, START),
    ("agent", agent_cli.agent, START),
    ("new-task", authoring_cli.new_task, START),
    ("collect", collect_cli.collect, PIPELINE),
    ("augment", augment_cli.augment, PIPELINE),
    ("convert", convert_cli.convert, PIPELINE),
    ("train", train_cli.train, PIPELINE),
    ("eval", evaluate_cli.eval_command, PIPELINE),
    ("serve", serve_cli.serve, PIPELINE),
):
    kind = evaluate_cli.EvalCommand if name == "eval" else None  # `eval report ...` goes to the report command
    app.command(name, cls=kind, short_help=_short(command), rich_help_panel=panel)(command)
for name, group in (
    ("tasks", tasks_cli.app),
    ("assets", assets_cli.app),
    ("experts", experts_cli.app),
    ("sim", sim_cli.app),
    ("data", data_cli.app),
):
    app.add_typer(group, name=name, rich_help_panel=LOOK)


@cache
def load_catalog() -> CommandCatalog:
    """The agent's catalog of this CLI (``pipette agent`` reads the CLI it is part of)."""
    return cli_catalog(app)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"pipette {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    verbose: Annotated[int, typer.Option("-v", "--verbose", count=True, help="More log output (repeatable).")] = 0,
    quiet: Annotated[bool, typer.Option("-q", "--quiet", help="Only warnings and errors.")] = False,
    debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks and debug logs.")] = False,
    registry_dir: Annotated[
        list[Path] | None,
        typer.Option(
            "--registry-dir", help="Extra folder of task YAML files (repeatable; also PIPETTE_REGISTRY_PATH)."
        ),
    ] = None,
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    """Global options; see each command's --help."""
    STATE.verbosity = -1 if quiet else verbose
    STATE.debug = debug
    STATE.registry_dirs = list(registry_dir or [])
    level = logging.DEBUG if debug or verbose >= 2 else logging.INFO if verbose == 1 else logging.WARNING
    logging.basicConfig(
        level=level, format="%(message)s", handlers=[RichHandler(console=err_console, show_path=False)], force=True
    )


def global_option_hint(error: Exception, args: list[str]) -> str | None:
    """For a usage error naming a global option given after the command (``pipette tasks show X
    --debug``), the same command line with it moved before the command; None otherwise."""
    name = getattr(error, "option_name", None)  # click's NoSuchOption
    params = {opt: p for p in typer.main.get_command(app).params for opt in (*p.opts, *p.secondary_opts)}
    if not name or name not in params or not name.startswith("-"):
        return None
    param = params[name]
    takes_value = not (getattr(param, "is_flag", False) or getattr(param, "count", False))
    moved: list[str] = []
    rest: list[str] = []
    i = 0
    while i < len(args):
        arg = args[i]
        repeated = len(name) == 2 and arg[:1] == "-" and arg[1:] and set(arg[1:]) == {name[1]}  # -vv
        if arg == name or repeated or (takes_value and arg.startswith(f"{name}=")):
            moved.append(arg)
            if arg == name and takes_value and i + 1 < len(args):
                moved.append(args[i + 1])
                i += 1
        else:
            rest.append(arg)
        i += 1
    return f"{name} is a global option, given before the command: {shlex.join(['pipette', *moved, *rest])}"


def run() -> None:
    """Console-script entry: run the app and map errors to exit codes."""
    try:
        code = app(standalone_mode=False)
    except PipetteError as exc:
        if STATE.debug:
            err_console.print_exception()
        problems = getattr(exc, "problems", None) or [str(exc)]
        for line in problems:
            err_console.print(f"[red]error:[/red] {escape(str(line))}", markup=True, highlight=False, soft_wrap=True)
        sys.exit(exc.exit_code)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except typer.Abort:
        err_console.print("aborted")
        sys.exit(130)
    except KeyboardInterrupt:
        err_console.print("interrupted")
        sys.exit(130)
    except typer.TyperException as exc:  # usage errors (exit 2) in non-standalone mode
        show = getattr(exc, "show", None)  # click usage errors print themselves
        if show is not None:
            show()
        else:
            err_console.print(f"[red]error:[/red] {escape(str(exc))}")
        hint = global_option_hint(exc, sys.argv[1:])
        if hint is not None:
            err_console.print(f"hint: {escape(hint)}", soft_wrap=True)
        sys.exit(exc.exit_code)
    sys.exit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    run()
