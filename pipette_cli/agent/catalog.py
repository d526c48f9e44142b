"""The CLI's own command schema, read from the typer app: what the agent may produce.

The agent never writes shell: a plan names one command of this catalog and values for its
parameters; :func:`CommandCatalog.argv` turns it into an argument list, and anything the
catalog does not define is refused. Commands that land later (train, serve, eval, ...) join
the catalog by being registered in the CLI.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
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
        """Required parameters of ``name`` that ``params`` lacks."""
        return [p for p in self.get(name).required() if params.get(p) in (None, "", [])]

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
            raise AgentError(f"'pipette {name}' needs {', '.join(missing)}")
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


@cache
def load_catalog() -> CommandCatalog:
    """Every leaf command of the ``pipette`` CLI with its parameters."""
    from pipette_cli.cli.main import app

    commands: dict[str, CommandInfo] = {}
    for path, command in _walk(typer.main.get_command(app)):
        if path[0] == "agent":
            continue  # the agent does not call itself
        params = {}
        for p in command.params:
            option = p.param_type_name == "option"
            long_flags = [o for o in p.opts if o.startswith("--")]
            params[p.name] = ParamInfo(
                name=p.name,
                flag=(long_flags[0] if long_flags else p.opts[0]) if option else None,
                required=bool(p.required),
                is_flag=bool(getattr(p, "is_flag", False)),
                multiple=bool(getattr(p, "multiple", False) or (not option and getattr(p, "nargs", 1) == -1)),
                default=p.default,
            )
        info = CommandInfo(path, params, (command.help or "").strip().splitlines()[0] if command.help else "")
        commands[info.name] = info
    return CommandCatalog(commands)
