"""The CLI's own command schema, read from the typer app: what the agent may produce.

Every leaf command of ``pipette`` (``eval report`` included), with each parameter's flag, type,
choices, range, default and help, is read from the typer app when the catalog is first used,
so the agent follows the CLI as it changes. The agent's read-only answers (``answer tasks``,
``answer demos``, ``answer score``, :mod:`.answers`) are typer commands too and are read the
same way. A plan names commands of this catalog and values for their parameters;
:meth:`CommandCatalog.argv` turns a step into an argument list, and anything the catalog does
not define is refused. The agent never writes shell.
"""

from __future__ import annotations

import enum
import re
import types
import typing
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import typer

from pipette_cli.agent.answers import app as answers_app
from pipette_cli.agent.vocabulary import load_vocabulary
from pipette_cli.errors import PipetteError, suggest
from pipette_cli.language.phrases import singular

TASK_PARAMS = ("task_id", "tasks", "task")
"""Parameters that name registered tasks."""
ANSWER = "answer"
"""Prefix of the agent's own read-only commands."""


class AgentError(PipetteError):
    """A request cannot become a plan (unknown command or parameter, bad or missing values)."""


class Unsupported(AgentError):
    """The request asks for something Pipette does not do (e.g. a policy it cannot train);
    asking an LLM again cannot fix it."""

    final = True


NEGATION = "(no|not|without|rather than|instead of|skip|skipping|skipp|minus|minu|sans|never) (the|any|a|an)?"
"""Words before a flag's name that switch it off (with their stems: the flags are read stemmed)."""


@dataclass(frozen=True)
class ParamInfo:
    """One parameter of a command, as the CLI defines it."""

    name: str
    flag: str | None
    """``--episodes`` for options, None for positional arguments."""
    required: bool
    kind: str
    """``int``, ``float``, ``bool``, ``str``, ``path`` or ``task``."""
    multiple: bool
    default: Any
    help: str = ""
    choices: tuple[str, ...] = ()
    """Values the CLI accepts (a ``click.Choice``)."""
    hinted: tuple[str, ...] = ()
    """Values the help lists ("raw or augmented", "act, smolvla or pi0"); not enforced."""
    minimum: float | None = None
    maximum: float | None = None
    off_flag: str | None = None
    """``--images`` for ``--video/--images``."""
    writes: bool = False
    """A path the command writes (``--out``, "file to create")."""
    address: bool = False
    """A network endpoint (``tcp://host:port``)."""
    names: tuple[str, ...] = ()
    """Words people use for it: its own name ("max steps", "json") and the vocabulary's
    ("checkpoint" for ``--pretrained-path``); they precede a number or switch a flag on."""
    units: tuple[str, ...] = ()
    """Words that follow a number meant for it ("demos" for ``--episodes``, "px")."""
    off_words: tuple[str, ...] = ()
    """Words that switch a flag off ("png images" for ``--video``)."""
    parse: Callable[[str], Any] | None = None
    """The CLI's own parser of a value (typer's ``parser=``): a plan's value goes through it too."""

    @property
    def is_flag(self) -> bool:
        return self.kind == "bool"

    def negated(self, name: str | None = None) -> tuple[str, ...]:
        """Phrases of a name of this flag after a word that switches it off ("without the physics
        build"); ``name`` instead of its names (a stemmed form)."""
        return tuple(f"{NEGATION} {n}" for n in ([name] if name is not None else self.names))

    @property
    def path(self) -> bool:
        return self.kind == "path"

    @property
    def comma_list(self) -> bool:
        """One option holding several values joined by "," (``--variants light,cam``)."""
        return not self.multiple and "comma" in self.help.lower()

    def values(self) -> tuple[str, ...]:
        return self.choices or self.hinted

    @property
    def takes_assets(self) -> bool:
        """An asset id (``assets show ID``; ``tasks new --asset``: help "Main object's asset id") or
        several (``assets render [ID...]``: help "Asset ids ...")."""
        return self.name == "asset_id" or "asset id" in self.help.lower()

    @property
    def indexed(self) -> tuple[str, ...]:
        """Values the help writes with an index ("cuda[:N]"): "cuda:1", "gpu 1" keep theirs."""
        return tuple(re.findall(r"([\w-]+)\[:N\]", self.help))


@dataclass(frozen=True)
class CommandInfo:
    """One leaf command: ``("data", "inspect")`` with its parameters in the CLI's order."""

    path: tuple[str, ...]
    params: dict[str, ParamInfo]
    help: str
    example: str = ""

    @property
    def name(self) -> str:
        return " ".join(self.path)

    @property
    def is_answer(self) -> bool:
        return self.path[0] == ANSWER

    def required(self) -> list[str]:
        return [p.name for p in self.params.values() if p.required]

    def task_param(self) -> ParamInfo | None:
        """The parameter that names a registered task (kind ``task``; ``new-task --id``, a new id, is none)."""
        return next((self.params[p] for p in TASK_PARAMS if p in self.params and self.params[p].kind == "task"), None)


def is_empty(value: Any) -> bool:
    return value is None or value == "" or value == []


def say_missing(missing: list[str]) -> str:
    """``["task_id", "endpoint|policy"]`` -> ``"task_id, endpoint or policy"``."""
    return ", ".join(m.replace("|", " or ") for m in missing)


@dataclass(frozen=True)
class CommandCatalog:
    commands: dict[str, CommandInfo]
    one_of: dict[str, tuple[str, ...]]
    """Options of which a command needs exactly one (it checks this when it runs, so its
    signature cannot show it); a step lacking all of them misses ``"endpoint|policy"``."""
    stands_in: dict[str, dict[str, str]] = field(default_factory=dict)
    """Per command, a required parameter another one can replace (``pipette eval --suite ID``
    needs no task): the parameter counts as given when its stand-in is."""

    def get(self, name: str) -> CommandInfo:
        try:
            return self.commands[name]
        except KeyError:
            raise AgentError(f"no command 'pipette {name}' in this version; {suggest(name, self.commands)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.commands

    def missing(self, name: str, args: dict[str, Any]) -> list[str]:
        """Required parameters of ``name`` that ``args`` lacks; a missing choice of
        :attr:`one_of` is one entry, its names joined by ``|``."""
        stand_ins = self.stands_in.get(name, {})
        required = set(self.get(name).required()) | set(stand_ins)
        missing = [
            p
            for p in self.get(name).params
            if p in required and is_empty(args.get(p)) and is_empty(args.get(stand_ins.get(p, "")))
        ]
        choice = self.one_of.get(name, ())
        if choice and all(is_empty(args.get(p)) for p in choice):
            missing.append("|".join(choice))
        return missing

    def argv(self, name: str, args: dict[str, Any]) -> list[str]:
        """The argument list (without the program name) for ``pipette name`` with ``args``.

        Raises:
            AgentError: an unknown parameter, or a required one missing.
        """
        info = self.get(name)
        for key in args:
            if key not in info.params:
                raise AgentError(f"'pipette {name}' has no parameter {key!r}; {suggest(key, info.params)}")
        missing = self.missing(name, args)
        if missing:
            raise AgentError(f"'pipette {name}' needs {say_missing(missing)}")
        return [*info.path, *render_args(info, args)]


def render_args(info: CommandInfo, args: dict[str, Any]) -> list[str]:
    """``args`` as command-line words in the CLI's parameter order (values as given)."""
    words: list[str] = []
    for param in info.params.values():
        value = args.get(param.name)
        if value is None:
            continue
        values = value if isinstance(value, list | tuple) else [value]
        if param.flag is None:
            words.extend(str(v) for v in values)
        elif param.is_flag:
            flag = param.flag if value else param.off_flag
            if flag:
                words.append(flag)
        else:
            for v in values:
                words.extend([param.flag, str(v)])
    return words


def _walk(command: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], Any]]:
    subs = getattr(command, "commands", None)
    if subs:
        for name, sub in subs.items():
            yield from _walk(sub, (*path, name))
    elif path:
        yield path, command
        for name, sub in getattr(command, "subcommands", {}).items():  # `eval report` (see cli/evaluate.py)
            yield (*path, name), sub


_VALUE = r"[\w.:-]+(?:\[:N\])?"
_HINTED = re.compile(rf"^(?:[\w -]+:\s*)?({_VALUE}(?:\s*\([^)]*\))?(?:,\s*{_VALUE}(?:\s*\([^)]*\))?)*\s+or\s+{_VALUE})")


def hinted_values(help_text: str) -> tuple[str, ...]:
    """Values a help text starts by listing: "raw or augmented; ..." -> ("raw", "augmented")."""
    m = _HINTED.match(help_text.strip())
    if not m:
        return ()
    text = re.sub(r"\([^)]*\)|\[:N\]", "", m.group(1))
    return tuple(v.strip().rstrip(".:") for v in re.split(r",|\bor\b", text) if v.strip().rstrip(".:"))


def _annotation(param: Any, hint: Any) -> tuple[Any, bool]:
    """The parameter's Python type (``Optional`` and ``list`` taken off) and whether it is a list.

    Typer >= 0.29 keeps the annotation on the parameter; older typer has click types, and the
    callback's type hints say the same.
    """
    descriptor = getattr(param, "type_descriptor", None)
    annotation = getattr(descriptor, "annotation", None) if descriptor is not None else None
    annotation = annotation if annotation is not None else hint
    is_list = False
    while True:
        origin, inner = typing.get_origin(annotation), [a for a in typing.get_args(annotation) if a is not type(None)]
        if origin in (list, tuple, set) and inner:
            annotation, is_list = inner[0], True
        elif origin in (typing.Union, types.UnionType) and len(inner) == 1:
            annotation = inner[0]
        else:
            return annotation, is_list


def _kind_and_choices(param: Any, hint: Any) -> tuple[str, tuple[str, ...]]:
    annotation, _ = _annotation(param, hint)
    if param.name in TASK_PARAMS:
        return "task", ()
    if (getattr(param, "is_flag", False) and not getattr(param, "count", False)) or annotation is bool:
        return "bool", ()
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return "str", tuple(str(m.value) for m in annotation)
    if typing.get_origin(annotation) is typing.Literal:
        return "str", tuple(str(v) for v in typing.get_args(annotation))
    if annotation is Path or (param.name or "").endswith("_path"):
        return "path", ()
    kinds = {int: "int", float: "float", str: "str"}
    if annotation in kinds:
        return kinds[annotation], ()
    click_type = getattr(param, "type", None)  # older typer: click types
    choices = tuple(str(c) for c in getattr(click_type, "choices", None) or ())
    name = getattr(click_type, "name", "")
    return {
        "integer": "int",
        "integer range": "int",
        "float": "float",
        "float range": "float",
        "boolean": "bool",
        "path": "path",
    }.get(name, "str"), choices


def _param(p: Any, hint: Any) -> ParamInfo:
    option = p.param_type_name == "option"
    help_text = (getattr(p, "help", None) or "").strip()
    kind, choices = _kind_and_choices(p, hint)
    if kind == "str" and not choices and re.search(r"\bor\b[^.]*\b(?:files?|folders?|path)\b", help_text):
        kind = "path"  # "Asset ids, .usda files or folders"
    name = p.name or ""
    long_flags = [o for o in p.opts if o.startswith("--")]
    secondary = [o for o in getattr(p, "secondary_opts", []) if o.startswith("--")]
    writes = kind == "path" and (
        name in ("out", "output", "output_root", "markdown", "report")
        or bool(re.search(r"\b(?:to write|to create|write)\b", help_text, re.I))
    )
    default = p.default if not callable(p.default) else None
    if isinstance(default, enum.Enum):
        default = default.value
    address = kind == "str" and bool(re.search(r"tcp://|\bendpoint\b", f"{help_text} {default}", re.I))
    limits = [
        getattr(p, attr, None) if getattr(p, attr, None) is not None else getattr(getattr(p, "type", None), attr, None)
        for attr in ("min", "max")
    ]
    return ParamInfo(
        name=name,
        flag=(long_flags[0] if long_flags else p.opts[0]) if option else None,
        required=bool(p.required),
        kind=kind,
        multiple=bool(p.multiple or (not option and p.nargs == -1)),
        default=default,
        help=help_text,
        choices=choices,
        hinted=() if choices or kind in ("bool", "path", "task") else hinted_values(help_text),
        minimum=limits[0],
        maximum=limits[1],
        off_flag=secondary[0] if secondary else None,
        writes=writes,
        address=address,
        parse=_parser(p),
    )


def _parser(param: Any) -> Callable[[str], Any] | None:
    """The parser a CLI option was given (typer's ``parser=``; older typer: a click ``FuncParamType``)."""
    info = getattr(getattr(param, "type_descriptor", None), "parameter_info", None)
    parser = getattr(info, "parser", None) or getattr(getattr(param, "type", None), "func", None)
    return parser if callable(parser) else None


def own_names(param: ParamInfo) -> tuple[str, ...]:
    """Words of a parameter's own name: ``max_steps`` / ``--max-steps`` -> "max steps"."""
    names = {param.name.replace("_", " ")} - {"as json"}
    if param.flag:
        names.add(param.flag.lstrip("-").replace("-", " "))
    return tuple(sorted(names))


def _with_words(command: str, param: ParamInfo) -> ParamInfo:
    spec = load_vocabulary().words_for(param.name, command)
    units = tuple(spec.units)
    if not units and param.kind in ("int", "float"):  # "4 threads", "3 distractors": a plural name follows its number
        plural = [n for n in own_names(param) if " " not in n and n.endswith("s")]
        units = (*plural, *(f"{singular(n)} *" for n in plural))  # "8 distractor objects": the noun it modifies
    return replace(param, names=(*spec.names, *own_names(param)), units=units, off_words=tuple(spec.off))


def _command(path: tuple[str, ...], command: Any) -> CommandInfo:
    hints = typing.get_type_hints(command.callback, include_extras=False) if command.callback else {}
    params = {p.name: _param(p, hints.get(p.name)) for p in command.params if p.name and p.name != "help"}
    if path[-1].startswith("new") or path[-1].endswith("new-task"):  # the id of a task to create
        params = {k: replace(v, kind="str") if v.kind == "task" else v for k, v in params.items()}
    params = {k: _with_words(" ".join(path), v) for k, v in params.items()}
    text = (command.help or "").strip()
    example = next((line.split("Example:", 1)[1].strip() for line in text.splitlines() if "Example:" in line), "")
    return CommandInfo(path, params, text.splitlines()[0] if text else "", example)


def read_catalog(*apps: tuple[typer.Typer | Any, tuple[str, ...]]) -> CommandCatalog:
    """The catalog of the typer ``apps``, each with the prefix its commands get (``("answer",)``)."""
    commands: dict[str, CommandInfo] = {}
    for root, prefix in apps:
        for path, command in _walk(typer.main.get_command(root) if isinstance(root, typer.Typer) else root, prefix):
            if path[0] != "agent":  # the agent does not call itself
                info = _command(path, command)
                commands[info.name] = info
    vocabulary = load_vocabulary()
    one_of = {k: tuple(v) for k, v in vocabulary.one_of.items() if k in commands}
    stands_in = {k: dict(v) for k, v in vocabulary.stands_in.items() if k in commands}
    for name, replaced in stands_in.items():  # required for planning, unless the stand-in is given
        info = commands[name]
        params = {k: replace(p, required=True) if k in replaced else p for k, p in info.params.items()}
        commands[name] = replace(info, params=params)
    return CommandCatalog(commands, one_of, stands_in)


def cli_catalog(cli: typer.Typer | Any) -> CommandCatalog:
    """Every leaf command of the ``pipette`` CLI ``cli`` (a typer app or its click group; all but
    ``agent``) and the agent's answers. The CLI is handed in: the agent is one of its commands."""
    return read_catalog((cli, ()), (answers_app, (ANSWER,)))
