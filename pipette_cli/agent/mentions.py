"""Paths and addresses in a request: found before any word is read, then given to options.

A path is a token with a ``/``, a file name with a known suffix (``x.h5``), or a name that exists
on disk and does not read as a plain word (it has a dot, underscore, dash or digit, so ``data``
stays a word where a ``data/`` folder exists). An address is ``tcp://host:port``, ``host:port``
or "port N" (on this machine). Both are blanked out of the words the parser reads, so
``outputs/train/act/...`` neither asks for ``pipette train`` nor names the ACT policy.

Each path goes to one path option of the command (:func:`assign_paths`): the option the words
just before it name ("the policy in ckpt/x", "from checkpoint ckpt/x"); an option the command
writes when they say where to put something ("to", "into", "save"); else the command's required
input, its path in a required choice (``eval --policy``), or its only path option.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipette_cli.agent.catalog import AgentError, CommandCatalog, CommandInfo, ParamInfo, is_empty

FILE_SUFFIXES = (
    "h5",
    "hdf5",
    "png",
    "jpg",
    "gif",
    "mp4",
    "yaml",
    "yml",
    "json",
    "csv",
    "md",
    "usd",
    "usda",
    "usdc",
    "safetensors",
    "pt",
    "log",
)
_SUFFIX = re.compile(rf"\.(?:{'|'.join(FILE_SUFFIXES)})$", re.IGNORECASE)
_URL = re.compile(r"^[a-z][a-z0-9+.-]*://\S+$", re.IGNORECASE)
_HOST_PORT = re.compile(r"^(?:localhost|[a-z0-9-]*[a-z][a-z0-9.-]*|\d{1,3}(?:\.\d{1,3}){3}):\d{2,5}$", re.IGNORECASE)
_PORT = re.compile(r"\bport\s*(?:number\s*)?[:=]?\s*(\d{2,5})\b", re.IGNORECASE)
_STRIP_LEFT, _STRIP_RIGHT = "([{\"'“‘<", ")]}\"'”’.,;:!?>"
SAVE_VERBS = "save|write|store|put|keep|place"
"""Verbs that ask a command to write somewhere."""
SAVE = re.compile(
    rf"\b(?:{SAVE_VERBS})s?\b(?:\s+(?:it|them|this|that|the \w+))?\s+"
    r"(?:to|in|into|under|at|as)$"
)
"""Words before a path that say the command should write there (present tense: "saved in" does not)."""
_TO = re.compile(r"\b(?:to|into|as)$")
_FROM = re.compile(r"\b(?:from|of)$")
LOCAL_HOST = "127.0.0.1"


@dataclass(frozen=True)
class PathMention:
    path: str
    before: str
    """Up to four lowercased words just before the path ("the policy in")."""
    listed: bool = False
    """It continues a list of paths ("a.h5 b.h5", "a.h5, b.h5", "a.h5 and b.h5")."""


@dataclass(frozen=True)
class Mentions:
    words: str
    """The request with paths and addresses taken out: what the parser reads as words."""
    paths: list[PathMention]
    addresses: list[tuple[str, str]]
    """(``tcp://host:port``, as written)."""


def _is_path(token: str) -> bool:
    if not re.search(r"[A-Za-z]", token) or not re.fullmatch(r"[\w.~/+-]+", token):
        return False
    if "/" in token or _SUFFIX.search(token):
        return True
    return bool(re.search(r"[._\-~\d]", token)) and Path(token).expanduser().exists()


def find_mentions(text: str, names: Iterable[str] = ()) -> Mentions:
    """Split ``text`` into its words, its paths and its addresses; ``names`` (task ids such as
    ``pipette/PickUpTestTube-v1``, alone or comma-separated) stay words although they hold a ``/``."""
    known = {n.lower() for n in names}
    kept: list[str] = []
    paths: list[PathMention] = []
    addresses: list[tuple[str, str]] = []
    since: list[str] | None = None  # words since the last path
    for token in text.split():
        core = token.strip(_STRIP_LEFT).rstrip(_STRIP_RIGHT)
        if core and _URL.match(core):
            addresses.append((core, core))
        elif core and _HOST_PORT.match(core):
            addresses.append((f"tcp://{core}", core))
        elif core and _is_path(core) and not all(part in known for part in core.lower().split(",")):
            before = " ".join(re.findall(r"[a-z0-9π-]+", " ".join(kept).lower())[-4:])
            listed = since is not None and all(w.strip(",") in ("", "and", "&") for w in since)
            paths.append(PathMention(core, before, listed))
            since = []
        else:
            kept.append(token)
            if since is not None:
                since.append(token.lower())
    words = " ".join(kept)
    for m in _PORT.finditer(words):
        addresses.append((f"tcp://{LOCAL_HOST}:{m.group(1)}", m.group(0)))
    return Mentions(_PORT.sub(" ", words), paths, addresses)


def option_words(param: ParamInfo) -> set[str]:
    """Words that name ``param`` (its name's parts and its vocabulary names, singular), without
    the generic "path"/"file"/"root"."""
    words = set(param.name.split("_")) | {w for name in param.names for w in name.split()}
    return {_singular(w) for w in words} - {"path", "root", "file", "the", "a", "in", "of", "to"}


def _singular(word: str) -> str:
    return word[:-1] if word.endswith("s") and len(word) > 3 else word


def _named(before: str, params: list[ParamInfo]) -> ParamInfo | None:
    """The option among ``params`` that the words before a path name ("the policy in")."""
    said = {_singular(w) for w in re.split(r"[\s-]+", before)[-3:]}
    return next((p for p in params if option_words(p) & said), None)


def assign_paths(info: CommandInfo, paths: list[PathMention], args: dict[str, Any], catalog: CommandCatalog) -> None:
    """Put each of ``paths`` into the path option of ``info`` it is for (``args`` is updated).

    Raises:
        AgentError: a path that fits none of the command's free path options.
    """
    options = [p for p in info.params.values() if p.path]

    def free(param: ParamInfo) -> bool:
        return param.multiple or is_empty(args.get(param.name))

    choice = catalog.one_of.get(info.name, ())
    named_strings = [p for p in info.params.values() if p.kind == "str" and not p.address and not p.values()]
    previous: ParamInfo | None = None
    for mention in paths:
        if previous is not None and previous.multiple and mention.listed:
            args[previous.name] = [*args.get(previous.name, []), mention.path]  # "a.h5 and b.h5"
            continue
        string = (
            None
            if _SUFFIX.search(mention.path) or _named(mention.before, options)
            else _named(mention.before, [p for p in named_strings if is_empty(args.get(p.name))])
        )
        if string is not None:  # "repo id me/centrifuge": a name with a slash, not a file
            args[string.name] = mention.path
            continue
        # of a choice (eval: endpoint or policy), one given bars the others
        barred = set(choice) if any(not free(info.params[c]) for c in choice) else set()
        writes = [p for p in options if p.writes and free(p) and p.name not in barred]
        reads = [p for p in options if not p.writes and free(p) and p.name not in barred]
        wants_output = bool(SAVE.search(mention.before) or _TO.search(mention.before))
        reads_from = bool(_FROM.search(mention.before))  # "a results table from evals/": a source, never an output
        candidates = [
            _named(mention.before, reads if reads_from else writes + reads),
            writes[0] if wants_output and writes else None,
            next((p for p in reads if p.required), None),
            next((p for p in reads if p.name in choice), None),
            reads[0] if len(reads) == 1 else None,
            writes[0] if len(options) == 1 and writes else None,
        ]
        target = next((p for p in candidates if p is not None), None)
        if target is None and not options:
            raise AgentError(f"'pipette {info.name}' takes no file or folder, but the request names {mention.path!r}")
        if target is None:
            flags = ", ".join(p.flag or p.name for p in options)
            example = f"{options[0].name.split('_')[0]} in {mention.path}"
            raise AgentError(
                f"cannot tell what {mention.path!r} is for in 'pipette {info.name}' (its path options: "
                f"{flags}); name it before the path, e.g. '{example}'"
            )
        if target.multiple:
            args[target.name] = [*args.get(target.name, []), mention.path]
        else:
            args[target.name] = mention.path
        previous = target
