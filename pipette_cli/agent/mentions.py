"""Where a request's paths go: each path found by :func:`pipette_cli.language.mentions.find_mentions`
goes to one path option of the command (:func:`assign_paths`): the option the words just before it
name ("the policy in ckpt/x", "from checkpoint ckpt/x"); an option the command writes when they say
where to put something ("to", "into", "save"); else the command's required input, its path in a
required choice (``eval --policy``), or its only path option.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from pathlib import Path
from typing import Any

from pipette_cli.agent.catalog import AgentError, CommandCatalog, CommandInfo, ParamInfo, is_empty
from pipette_cli.language.mentions import FILE_SUFFIX, PathMention
from pipette_cli.language.phrases import singular
from pipette_cli.specs.task import TASK_ID_PATTERN

SAVE_VERBS = "save|write|store|put|keep|place"
"""Verbs that ask a command to write somewhere."""
SAVE = re.compile(
    rf"\b(?:{SAVE_VERBS})s?\b(?:\s+(?:the |its |their )?\w+)?\s+"
    r"(?:to|in|into|under|at|as)$"
)
"""Words before a path that say the command should write there ("save it to", "keep the rejects in", "save
checkpoints to"; present tense: "saved in" does not)."""
_TO = re.compile(r"\b(?:to|into|as|write|writes|save|saves|store|stores)$")
"""Words right before a path that make it where the command writes ("... into x.h5", "and write x.h5")."""
_INTO = re.compile(r"\b(?:to|into)$")
"""Where something goes ("the clutter suite, into evals/x"): a path, never a name after it."""
_FROM = re.compile(r"\b(?:from|of)$")


def names_no_file(path: str) -> bool:
    """Whether ``path`` is written as a task id ("mylab/CloseBigCentrifuge-v1") and no such file or
    folder exists: a task's name, never a path."""
    return re.match(TASK_ID_PATTERN, path) is not None and not Path(path).exists()


def option_words(param: ParamInfo) -> set[str]:
    """Words that name ``param`` (its name's parts and its vocabulary names, singular), without
    the generic "path"/"file"/"root" unless they are its whole name (``convert --root``)."""
    words = set(param.name.split("_")) | {w for name in param.names for w in name.split()}
    generic = {"path", "root", "file", "the", "a", "in", "of", "to", "from", "at", "with", "for", "on", "by"} - {
        param.name
    }
    return {singular(w) for w in words} - generic


def _named(before: str, params: list[ParamInfo], values: AbstractSet[str] = frozenset()) -> ParamInfo | None:
    """The option among ``params`` that the words before a path name ("the policy in"), the one they
    name with the most words ("backbone weights in": ``--act-backbone-weights``, not ``--pretrained-path``
    for "weights" alone; ties: the first); a word that is a value of the command ("train ACT on x": the
    policy) names no option."""
    said = {singular(w) for t in before.split()[-3:] for w in (t, *t.split("-"))} - values  # "fine-tune", "tune"
    best = max(params, key=lambda p: len(option_words(p) & said), default=None)
    return best if best is not None and option_words(best) & said else None


def assign_paths(
    info: CommandInfo,
    paths: list[PathMention],
    args: dict[str, Any],
    catalog: CommandCatalog,
    readers: dict[str, list[str]] | None = None,
    file_inputs: AbstractSet[str] = frozenset(),
    consumed: Mapping[str, str] | None = None,
    files: Mapping[str, str] | None = None,
) -> None:
    """Put each of ``paths`` into the path option of ``info`` it is for (``args`` is updated);
    a path written as a folder ("videos/") never goes to one of ``file_inputs``, a file of a kind
    ``files`` names (``h5``: demos) never to an option ``consumed`` says reads another kind.

    Raises:
        AgentError: a path that fits none of the command's free path options.
    """
    options = [p for p in info.params.values() if p.path]

    def free(param: ParamInfo) -> bool:
        return param.multiple or is_empty(args.get(param.name))

    choice = catalog.one_of.get(info.name, ())
    values = {v.lower() for p in info.params.values() if not p.path for v in p.values()}
    # the one-word name of another option names that option, not a path ("4 variants each, into x.h5": not
    # --rejected, whose "rejected variants" holds the word)
    values |= {singular(p.name) for p in info.params.values() if not p.path and "_" not in p.name}
    named_strings = [p for p in info.params.values() if p.kind == "str" and not p.address and not p.values()]
    previous: ParamInfo | None = None
    for mention in paths:
        if previous is not None and previous.multiple and mention.listed:
            args[previous.name] = [*args.get(previous.name, []), mention.path]  # "a.h5 and b.h5"
            continue
        strings = [p for p in named_strings if is_empty(args.get(p.name))]
        named = None if _INTO.search(mention.before) else _named(mention.before, options + strings, values)
        # a name with a slash ("repo id me/centrifuge"), or a value the words name that is no path option's
        # ("the backbone weights in w/r18.pt": the option says what it takes)
        string = named if named in strings else None
        if string is None and names_no_file(mention.path):
            string = next((p for p in named_strings if p.name.endswith("id") and is_empty(args.get(p.name))), None)
        if string is not None:  # "repo id me/centrifuge", "as mylab/X-v1": a name with a slash, not a file
            args[string.name] = mention.path
            continue
        # of a choice (eval: endpoint or policy), one given bars the others
        barred = set(choice) if any(not free(info.params[c]) for c in choice) else set()
        writes = [p for p in options if p.writes and free(p) and p.name not in barred]
        folder = mention.path.endswith("/")  # "GIFs of them in videos/incub/": an output, not the input file
        suffix = mention.path.rsplit(".", 1)[-1].lower() if FILE_SUFFIX.search(mention.path) else ""
        other_file = bool(suffix) and suffix not in (readers or {})  # "a gif of it at x.gif": never the .h5 read
        # an option that reads another kind of thing never takes the file ("compare a.h5 and b.h5": eval report
        # reads evaluation folders, not demos)
        kind = (files or {}).get(suffix)
        unread = {o for o, k in (consumed or {}).items() if kind and k != kind}
        reads = [
            p
            for p in options
            if not p.writes
            and free(p)
            and p.name not in barred
            and not ((folder or other_file) and p.name in file_inputs)
            and p.name not in unread
        ]
        saves = bool(SAVE.search(mention.before))  # "save checkpoints to runs/x": where it writes, never a read
        wants_output = saves or bool(_TO.search(mention.before))
        reads_from = bool(_FROM.search(mention.before))  # "a results table from evals/": a source, never an output
        candidates = [
            _named(mention.before, reads if reads_from else writes if saves else writes + reads, values),
            writes[0] if wants_output and writes else None,
            next((p for p in reads if p.required), None),
            next((p for p in reads if p.name in choice), None),
            reads[0] if len(reads) == 1 else None,
            writes[0] if len(options) == 1 and writes else None,
            writes[0] if folder and len(writes) == 1 else None,  # a folder no input takes: where output goes
            writes[0] if other_file and len(writes) == 1 else None,  # a file no input reads ("at x.gif")
        ]
        target = next((p for p in candidates if p is not None), None)
        others = [c for c in (readers or {}).get(suffix, []) if c != info.name]
        if target is None and others:  # "train on data/x.h5": a file this command does not read
            said = ", ".join(f"pipette {c}" for c in others)
            raise AgentError(
                f"'pipette {info.name}' does not read {mention.path!r} (a .{suffix} file); {said} do: e.g. "
                f"'{others[0]} {mention.path}, then {info.name} ...'"
            )
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
