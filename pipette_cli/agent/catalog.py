"""The CLI's own command schema, read from the typer app: what the agent may produce.

The agent never writes shell: a plan names one command of this catalog and values for its
parameters; :func:`CommandCatalog.argv` turns it into an argument list, and anything the
catalog does not define is refused. A command joins the catalog by being registered in the CLI.
"""

from __future__ import annotations

import re
import typing
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import typer

from pipette_cli.errors import PipetteError, suggest


@dataclass(frozen=True)
class ParamInfo:
    name: str
    flag: str | None
    """``--episodes`` for options, None for positional arguments."""
    required: bool
    is_flag: bool
    multiple: bool
    default: Any
    help: str = ""
    path: bool = False
    """Takes a file or folder (typed ``Path``, named ``*_path``, or "ids or files" in its help)."""
    writes: bool = False
    """A path the command writes (``--out``, ``--output``, "file to create")."""


@dataclass(frozen=True)
class CommandInfo:
    path: tuple[str, ...]
    params: dict[str, ParamInfo]
    help: str

    @property
    def name(self) -> str:
        return " ".join(self.path)

    def required(self) -> list[str]:
        return [p.name for p in self.params.values() if p.required]


class AgentError(PipetteError):
    """A request cannot become a command (unknown command or parameter, missing values)."""


ONE_OF: dict[str, tuple[str, ...]] = {"eval": ("endpoint", "policy")}
"""Options of which a command needs exactly one. The command checks this when it runs, so its
signature cannot show it; a plan lacking all of them misses ``"endpoint|policy"``."""
STANDS_IN: dict[str, dict[str, str]] = {"eval": {"task_id": "suite_id"}}
"""A parameter another one can replace (``pipette eval --suite ID`` needs no task): the agent
treats it as required unless the other is given."""


def say_missing(missing: list[str]) -> str:
    """``["task_id", "endpoint|policy"]`` -> ``"task_id, endpoint or policy"``."""
    return ", ".join(m.replace("|", " or ") for m in missing)


@dataclass(frozen=True)
class CommandCatalog:
    commands: dict[str, CommandInfo]

    def get(self, name: str) -> CommandInfo:
        try:
            return self.commands[name]
        except KeyError:
            raise AgentError(f"no command 'pipette {name}' in this version; {suggest(name, self.commands)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.commands

    def missing(self, name: str, params: dict[str, Any]) -> list[str]:
        """Required parameters of ``name`` that ``params`` lacks; a missing choice of
        :data:`ONE_OF` is one entry, its names joined by ``|``."""
        stand_ins = STANDS_IN.get(name, {})
        missing = [p for p in self.get(name).required()
                   if params.get(p) in (None, "", []) and params.get(stand_ins.get(p, "")) in (None, "", [])]
        choice = ONE_OF.get(name, ())
        if choice and all(params.get(p) in (None, "", []) for p in choice):
            missing.append("|".join(choice))
        return missing

    def argv(self, name: str, params: dict[str, Any]) -> list[str]:
        """The argument list (without the program name) for ``pipette name`` with ``params``.

        Raises:
            AgentError: an unknown parameter, or a required one missing.
        """
        info = self.get(name)
        for key in params:
            if key not in info.params:
                raise AgentError(f"'pipette {name}' has no parameter {key!r}; {suggest(key, info.params)}")
        missing = self.missing(name, params)
        if missing:
            raise AgentError(f"'pipette {name}' needs {say_missing(missing)}")
        args: list[str] = list(info.path)
        for param in info.params.values():  # keep the CLI's own order
            value = params.get(param.name)
            if value is None or value is False:
                continue
            values = value if isinstance(value, list | tuple) else [value]
            if param.flag is None:
                args.extend(str(v) for v in values)
            elif param.is_flag:
                args.append(param.flag)
            else:
                for v in values:
                    args.extend([param.flag, str(v)])
        return args


def _walk(command: Any, path: tuple[str, ...] = ()):
    subs = getattr(command, "commands", None)
    if subs:
        for name, sub in subs.items():
            yield from _walk(sub, (*path, name))
    elif path:
        yield path, command
        for name, sub in getattr(command, "subcommands", {}).items():  # `eval report` (see cli/evaluate.py)
            yield (*path, name), sub


def _mentions_path(annotation: Any) -> bool:
    """``Path``, ``Path | None``, ``list[Path]``, ..."""
    return annotation is Path or any(_mentions_path(a) for a in typing.get_args(annotation))


@cache
def load_catalog() -> CommandCatalog:
    """Every leaf command of the ``pipette`` CLI with its parameters."""
    from pipette_cli.cli.main import app

    commands: dict[str, CommandInfo] = {}
    for path, command in _walk(typer.main.get_command(app)):
        if path[0] == "agent":
            continue  # the agent does not call itself
        hints = typing.get_type_hints(command.callback) if command.callback else {}
        params = {}
        for p in command.params:
            option = p.param_type_name == "option"
            long_flags = [o for o in p.opts if o.startswith("--")]
            help_text = getattr(p, "help", None) or ""
            is_flag = bool(getattr(p, "is_flag", False))
            takes_path = _mentions_path(hints.get(p.name)) or p.name.endswith("_path") or (
                not is_flag and bool(re.search(r"\bor\b[^.]*\b(?:files?|folders?|path)\b", help_text))
            )  # "Asset ids, .usda files or folders"
            params[p.name] = ParamInfo(
                name=p.name,
                flag=(long_flags[0] if long_flags else p.opts[0]) if option else None,
                required=bool(p.required) or p.name in STANDS_IN.get(" ".join(path), {}),
                is_flag=is_flag,
                multiple=bool(getattr(p, "multiple", False) or (not option and getattr(p, "nargs", 1) == -1)),
                default=p.default,
                help=help_text,
                path=takes_path,
                writes=takes_path and (p.name in ("out", "output", "output_root")
                                 or bool(re.search(r"\b(?:to write|to create|write)\b", help_text, re.I))),
            )
        info = CommandInfo(path, params, (command.help or "").strip().splitlines()[0] if command.help else "")
        commands[info.name] = info
    return CommandCatalog(commands)
