"""Filling one step of the offline agent's plan: a clause's words -> the arguments of its command.

Paths and addresses are taken out first (:mod:`pipette_cli.language.mentions`, then
:mod:`.mentions` for where each path goes) and fill the command's path and address options; the
remaining words give the task (matched against the registry, :mod:`.tasks`), the policy, numbers
next to the words of an option ("30 demos", "seed 3", "64 px"), values named by their words ("on
the gpu", "augmented"), flags ("as json", "dry run") and free text.
"""

from __future__ import annotations

import re
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, replace
from typing import Any

from pipette_cli.agent.catalog import TASK_PARAMS, AgentError, CommandCatalog, CommandInfo, is_empty
from pipette_cli.agent.clauses import Intents
from pipette_cli.agent.mentions import SAVE, assign_paths, names_no_file, option_words
from pipette_cli.agent.numbers import control_rate, counted, read_numbers
from pipette_cli.agent.products import train_run_of
from pipette_cli.agent.tasks import TaskIndex, task_in_file_name
from pipette_cli.agent.vocabulary import WorkflowVocabularySpec, distributed
from pipette_cli.errors import TaskNotFound
from pipette_cli.language.assets import load_vocabulary as load_asset_words
from pipette_cli.language.lexicon import short_name, stem, stem_phrase, stems
from pipette_cli.language.mentions import ARROW, PathMention, find_mentions
from pipette_cli.language.phrases import find_phrase, phrase_pattern, singular, words_of
from pipette_cli.registry import Registry


def _matches(phrases: list[str], text: str) -> list[re.Match[str]]:
    """Every match of each of ``phrases`` in ``text``."""
    return [m for p in phrases for m in phrase_pattern(p).finditer(text)]


_CORRECTION = re.compile(r"\b(?:actually|instead|rather|i mean|no wait|correction)\b")
_QUOTED = re.compile(r"[\"“'‘](.+?)[\"”'’](?!\w)")


PARTS_SUFFIX = ".parts"
"""The folder of a file's pending episodes (:func:`pipette_cli.demos.store.parts_dir`)."""


def files_of_parts(paths: list[PathMention]) -> list[PathMention]:
    """``paths`` with a pending-parts folder ("x.h5.parts") read as its file, each file once: "left
    x.h5.parts behind; pack them into x.h5" names one file."""
    out: list[PathMention] = []
    for mention in paths:
        path = mention.path.rstrip("/")
        if path.endswith(PARTS_SUFFIX) and len(path) > len(PARTS_SUFFIX):
            mention = replace(mention, path=path.removesuffix(PARTS_SUFFIX))
        if all(m.path != mention.path for m in out):
            out.append(mention)
    return out


@dataclass
class ArgumentReader:
    """Reads the arguments of one command from a clause (see the module docstring)."""

    catalog: CommandCatalog
    registry: Registry
    vocab: WorkflowVocabularySpec
    index: TaskIndex
    intents: Intents
    readers: dict[str, list[str]]

    def fill(
        self, info: CommandInfo, text: str, problems: list[str] | None = None, bound: AbstractSet[float] = frozenset()
    ) -> dict[str, Any]:
        """Arguments of ``info`` that ``text`` gives; a task that is unknown or ambiguous is
        added to ``problems`` (raised at once without it). Numbers in ``bound`` belong to an
        option of another step: never a bare count here."""
        mentions = find_mentions(text, self.registry.ids())
        words = words_of(distributed(mentions.words, self.vocab.distributes))  # "object and clutter variants"
        args: dict[str, Any] = {}
        unplaced = text  # "into data/x.h5" says where a file goes, not that the task places something
        for path in mentions.paths:
            unplaced = re.sub(
                rf"(?:(?<![\w-])(?:into|onto|to|in|under|at|from|as)\s+|\s*(?:{ARROW.pattern})\s*){re.escape(path.path)}",
                " ",
                unplaced,
            )
        named = self._registry_names(
            info, mentions.words if unplaced == text else find_mentions(unplaced, self.registry.ids()).words
        )
        try:
            self._task(info, named, words_of(named), args, [m.path for m in mentions.paths])
        except AgentError as exc:
            if problems is None:
                raise
            problems.append(str(exc))
        for address, raw in mentions.addresses:
            param = next((p for p in info.params.values() if p.address and is_empty(args.get(p.name))), None)
            plain = next(
                (
                    p
                    for p in info.params.values()
                    if p.kind == "str" and "address" in p.names and is_empty(args.get(p.name))
                ),
                None,
            )  # "the ray cluster at host:port"
            if param is None and plain is None:
                raise AgentError(f"'pipette {info.name}' takes no address like {raw!r}")
            if param is not None:
                args[param.name] = address
            elif plain is not None:
                args[plain.name] = raw
        runs_a_task = info.task_param() is not None  # `tasks new ID` names a new one
        paths = [
            m for m in files_of_parts(mentions.paths) if not (runs_a_task and self._unknown_task(m.path, problems))
        ]
        if "description" in info.params:  # free text: only "save it to PATH" is a path, the rest describes
            paths = [m for m in paths if SAVE.search(m.before) or names_no_file(m.path)]  # "..., id mylab/X-v1"
        if {"output_root", "policy", "tasks", "dataset_version"} <= set(info.params):  # "continue training <run>"
            ids = self.registry.ids()
            for m in list(paths):
                found = train_run_of(m.path, ids)
                if found is not None:
                    args.update({k: v for k, v in found.items() if is_empty(args.get(k))})
                    paths.remove(m)
        assign_paths(
            info,
            paths,
            args,
            self.catalog,
            self.readers,
            self.vocab.file_inputs(info.name),
            self.vocab.consumed(info.name),
            self.vocab.files,
        )
        saved = [m.path for m in paths]
        policy = self.policy(words)
        if policy:
            param = next((p for p in info.params.values() if set(p.values()) & set(self.vocab.policies)), None)
            if param is not None:
                args[param.name] = policy
        words = self._indexed(info, words, args)
        words = self._ranges(info, words, args)
        copied = self.vocab.task_params.get(info.name)
        if copied and is_empty(args.get(copied)) and self.index.explicit(mentions.words):
            args[copied] = self.index.explicit(mentions.words)[0]  # "copy CloseCentrifugeLid into ..."
        quoted = "description" in info.params and _QUOTED.search(mentions.words)  # its numbers describe the task
        said = words_of(distributed(_QUOTED.sub(" ", mentions.words), self.vocab.distributes)) if quoted else words
        read_numbers(self.vocab, info, said, args, bound, control_rate(self.registry, info, args))
        self._values(info, words, args)
        if copied and is_empty(args.get(copied)) and self._copies(info, words):
            match = self.index.match(_QUOTED.sub(" ", mentions.words))  # "a copy of the water bath lid task"
            if match.task:
                args[copied] = match.task
        self._flags(info, words, args)
        self._text(info, text, saved, mentions.words, words, args)
        self._implied(info, args)
        return args

    def _implied(self, info: CommandInfo, args: dict[str, Any]) -> None:
        """Values the options set need (vocabulary ``implies``): "a 15-step noise window" -> noise
        variants; "with lighting and a 15-step noise window" -> light,noise (a comma list grows); a
        value the list (or the default) already holds is not added ("speed factor 1.5": paper has speed)."""
        for option, needs in self.vocab.implies.get(info.name, {}).items():
            if args.get(option) in (None, False, "", []):
                continue
            for name, value in needs.items():
                param = info.params.get(name)
                if param is None:
                    continue
                have = str(args.get(name) or param.default or "")
                holds = self.vocab.contains.get(name, {})
                said = {w for part in re.split(r"[,+*\s]+", have) for w in (part, *holds.get(part, []))}
                if value in said:
                    continue  # the list, or the default, holds it
                if is_empty(args.get(name)):
                    args[name] = value
                elif param.comma_list:
                    args[name] = f"{args[name]},{value}"

    def _each_task(self, text: str) -> list[str]:
        """The tasks of a list of described tasks ("the tube pick-up and the centrifuge lid
        closing"), when each of its parts names one by its name or its action; else ``[]``."""
        found: list[str] = []
        for part in re.split(r"\s*(?:,|;|\(|\)|\band\b|\bplus\b|&)\s*", text):
            match = self.index.match(part) if self.index.names_a_task(part) else None
            if match is not None and match.candidates:
                return []  # one part is ambiguous: the request could mean several lists
            if match is not None and match.task and match.task not in found:
                found.append(match.task)
        return found

    def _copies(self, info: CommandInfo, words: str) -> bool:
        """Whether ``words`` ask ``info`` for a copy ("make a copy of the X task"): the verbs of
        its vocabulary cues, whose task is the one copied."""
        cues = self.vocab.intents.get(info.name)
        return cues is not None and find_phrase(cues.verbs, words) is not None

    def _registry_names(self, info: CommandInfo, text: str) -> str:
        """``text`` without the suite it names ("the paper benchmark suite" names no task)."""
        if "suite_id" not in info.params:
            return text
        phrases = [p for names in self.vocab.values.get("suite_id", {}).values() for p in names]
        lowered = words_of(text)
        m = find_phrase(sorted(phrases, key=len, reverse=True), lowered)
        return lowered[: m.start()] + " " + lowered[m.end() :] if m else text

    def _task(self, info: CommandInfo, raw: str, words: str, args: dict[str, Any], paths: list[str]) -> None:
        param = info.task_param()
        if param is None or info.name == "new-task":  # new-task's --id names the task to create
            return
        if self.index.all_tasks(words):
            args[param.name] = "all"
            return
        unknown = self.index.unknown_name(raw)
        cues = self.intents.cue_tokens(raw, info.name)  # "grab 45 demos": grab asks for collect, not for picking
        phrases = [*self.vocab.happened, *self.vocab.resumes]  # "was stopped", "resume it": no task's words
        for name, option in info.params.items():  # "the paper grid" is a value of --variants, not the paper's tasks
            names = [n for n in option.names if " " in n and name not in TASK_PARAMS]  # "light scale 0.6": no balance
            phrases += [*self._value_phrases(name), *names]
        spans = [m.span() for phrase in phrases for m in phrase_pattern(phrase).finditer(raw)]
        for start, end in spans:  # all found in the words as said: "lighting scale" is light's scale, "lighting" too
            raw = raw[:start] + " " * (end - start) + raw[end:]
        match = self.index.match(" ".join(w for w in raw.split() if w.lower().strip(",.;:!?") not in cues))
        in_file = next((t for t in (task_in_file_name(p, self.registry.ids()) for p in paths) if t), None)
        if in_file and param.required and not match.explicit and (match.task is None or in_file in match.candidates):
            args[param.name] = in_file  # "my centrifuge demos in data/OpenCentrifugeLid.h5"
        elif match.explicit:
            many = param.multiple or param.comma_list
            args[param.name] = list(match.explicit) if many else match.explicit[0]
        elif (param.multiple or param.comma_list) and len(each := self._each_task(raw)) > 1:
            args[param.name] = each  # "the tube pick-up and the centrifuge lid closing"
        elif unknown:
            raise AgentError(f"unknown task {unknown!r}; {self.index.suggest_name(short_name(unknown))}")
        elif match.task:
            args[param.name] = match.task
        elif match.candidates:
            raise AgentError(f"the request could mean several tasks: {', '.join(match.candidates)}; name one")
        elif match.opposed:
            raise AgentError(
                f"no registered task does what the request asks ({match.action!r} that): {', '.join(match.opposed)} "
                f"{'does' if len(match.opposed) == 1 else 'do'} the opposite; name a task, or create one "
                'with `pipette new-task "<what the robot should do>"`'
            )
        elif match.other:
            raise AgentError(
                f"no registered task does what the request asks ({match.action!r}): {', '.join(match.other)} "
                f"{'does' if len(match.other) == 1 else 'do'} something else with what it names; name a task, or "
                'create one with `pipette new-task "<what the robot should do>"`'
            )
        elif param.required or info.is_answer:
            named = re.search(
                r"\b(?:of|for|on)\s+(?:the\s+|a\s+|an\s+)?([a-z][\w-]*(?:\s+[a-z][\w-]*){0,2}?)\s+task\b", words
            )
            stop = {stem(w) for w in self.vocab.tasks.stop} | {w for w, _ in self.vocab.policy_words()}
            back = {"same", "previous", "last", "earlier", "that", "this", "above"}  # "the same suite and task"
            said = named.group(1).split() if named else []
            others = {"new", "first", "next", "one", "which", "what"}
            if named and not back & set(said) and not {stem(w) for w in said} <= stop | others:
                raise AgentError(f"unknown task {named.group(1)!r}; {self.index.suggest_name(named.group(1))}")
            work = self.index.unmatched_work(raw)
            if work:  # "record 10 demos of opening the autoclave door": no task does that
                raise AgentError(
                    f"no registered task does {work!r}; name a task (`pipette tasks list`), or create one with "
                    f'`pipette new-task "{work}"`'
                )

    def policy(self, words: str) -> str | None:
        for word, key in self.vocab.policy_words():
            if re.search(rf"(?<![\w-]){re.escape(word)}(?![\w-])", words):
                return key
        return None

    def _values(self, info: CommandInfo, words: str, args: dict[str, Any]) -> None:
        """Values named by their words: vocabulary values anywhere, CLI choices anywhere, values
        the help lists only next to the option's name ("wrist camera")."""
        corrected = _CORRECTION.search(words) is not None
        claims = {  # a value's name of several words claims them: "the cpu reproduction suite" is no --device cpu
            name: [m.span() for p in self._value_phrases(name) if " " in p for m in phrase_pattern(p).finditer(words)]
            for name in info.params
        }
        everything = words
        for param in info.params.values():
            if not is_empty(args.get(param.name)) or param.kind in ("bool", "path", "task"):
                continue
            if set(param.values()) & set(self.vocab.policies):
                continue  # policies are read by _policy
            words = everything
            for start, end in (span for other, spans in claims.items() if other != param.name for span in spans):
                words = words[:start] + " " * (end - start) + words[end:]
            found: list[tuple[int, int, str]] = []  # (start, -length, value): the longest name at a place wins
            for value, phrases in self.vocab.values.get(param.name, {}).items():
                m = find_phrase(phrases, words)
                if m:
                    found.append((m.start(), -len(m.group(0)), value))
            for value in param.choices:
                m = re.search(rf"(?<![\w-]){re.escape(value.lower())}(?![\w-])", words)
                if m:
                    found.append((m.start(), -len(m.group(0)), value))
            names = "|".join(phrase_pattern(n).pattern for n in param.names)
            named = {p.lower() for p in self._value_phrases(param.name)}
            for value in (v for v in param.hinted if v.lower() not in named):  # the lexicon's value wins
                v = re.escape(value.lower())
                if re.search(r"[\d_]", value):  # "h264", "catmull_rom": never an ordinary word
                    m = re.search(rf"(?<![\w-]){v}(?![\w-])", words)
                else:
                    m = re.search(
                        rf"(?<![\w-]){v}(?:\s+\S+)?\s+(?:{names})|(?:{names})(?:\s+\S+)?\s+{v}(?![\w-])", words
                    )
                if m:
                    found.append((m.start(), -len(m.group(0)), value))
            if param.comma_list:  # "the light+cam variant": atoms joined as the CLI writes them
                atoms = set(self.vocab.values.get(param.name, {})) | set(param.choices)
                for m in re.finditer(r"(?<![\w+-])([a-z]+(?:\+[a-z]+)+)(?![\w+-])", words):
                    if set(m.group(1).split("+")) <= atoms:  # its atoms are said by it, not on their own
                        found = [f for f in found if f[2].partition("*")[0] not in m.group(1).split("+")]
                        found.append((m.start(), -len(m.group(1)), m.group(1)))
            if found and param.comma_list and "NAME*N" in param.help:  # "three object-pose draws": object*3
                found = counted(self.vocab, words, found, self.vocab.uncounted.get(param.name, []))
            if found and param.comma_list and not corrected:  # "object pose and camera shake"
                args[param.name] = ",".join(dict.fromkeys(value for _, _, value in sorted(found)))
            elif found:  # the first named, or the last after a correction ("..., actually just the paper variants")
                args[param.name] = max(found)[2] if corrected else min(found)[2]

    def _value_phrases(self, name: str) -> list[str]:
        """The vocabulary's words for every value of the option ``name``."""
        return [p for phrases in self.vocab.values.get(name, {}).values() for p in phrases]

    def _indexed(self, info: CommandInfo, words: str, args: dict[str, Any]) -> str:
        """A value the help writes with an index ("cuda[:N]") said with one ("cuda:1", "gpu 1"):
        the value with it, and ``words`` without the index (never a count)."""
        for param in (p for p in info.params.values() if is_empty(args.get(p.name))):
            for value in param.indexed:
                names = [value, *self.vocab.values.get(param.name, {}).get(value, [])]
                said = "|".join(phrase_pattern(p).pattern for p in names)
                m = re.search(rf"(?<![\w-])(?:{said})\s*:?\s*(\d+)(?![\w.-])", words)
                if m:
                    args[param.name] = f"{value}:{m.group(1)}"
                    words = words[: m.start(1)] + " " * len(m.group(1)) + words[m.end(1) :]
        return words

    def _ranges(self, info: CommandInfo, words: str, args: dict[str, Any]) -> str:
        """A range of an option's values ("seeds 100 to 149"): its first value and the count of the
        option that counts it (``--seed 100 --episodes 50``); ``words`` without it (never a bare count)."""
        for name, spec in self.vocab.ranges.items():
            if not {name, spec.count} <= set(info.params) or not is_empty(args.get(name)):
                continue
            m = spec.pattern().search(words)
            if m and int(m.group(2)) >= int(m.group(1)) and is_empty(args.get(spec.count)):
                args[name], args[spec.count] = int(m.group(1)), int(m.group(2)) - int(m.group(1)) + 1
                words = words[: m.start()] + " " * (m.end() - m.start()) + words[m.end() :]
        return words

    def both(self, info: CommandInfo, words: str) -> tuple[str, list[str]] | None:
        """A parameter the clause gives two values joined by "and" ("the raw and the augmented
        data"), or asks for every value ("on each robot"), for a command that takes one: the step is made
        once per value."""
        for name, phrases in self.vocab.every.items():
            param = info.params.get(name)
            if param is not None and not param.multiple and self.vocab.values.get(name) and find_phrase(phrases, words):
                return name, list(self.vocab.values[name])
        for param in info.params.values():
            if param.multiple or param.comma_list or param.kind != "str":
                continue
            found = sorted(  # each value where its words are closest together ("the nominal and shifted
                # augmentation suites": "shifted augmentation", not "augmentation suites and shifted")
                (m.start(), m.end(), value)
                for value, phrases in self.vocab.values.get(param.name, {}).items()
                for m in [min(_matches(phrases, words), key=lambda m: (len(m.group(0)), m.start()), default=None)]
                if m
            )
            values = list(dict.fromkeys(v for _, _, v in found))
            if len(values) >= 2 and re.search(r"\b(?:and|&)\b", words[found[0][1] : found[1][0]]):
                return param.name, values
        return None

    def _flags(self, info: CommandInfo, words: str, args: dict[str, Any]) -> None:
        stemmed = stems(words)
        flags = [p for p in info.params.values() if p.is_flag and p.name not in ("yes",)]
        said = {p.name: find_phrase([stem_phrase(w) for w in p.names], stemmed) for p in flags}
        for param in flags:
            on = said[param.name]
            inside = on is not None and any(  # "allow mixed robots" is no "allow mixed" (tasks) as well
                m is not None and m.start() <= on.start() and on.end() <= m.end() and m.span() != on.span()
                for m in said.values()
            )
            negated = [p for w in param.names for p in param.negated(stem_phrase(w))]  # "without the physics build"
            if find_phrase([*(stem_phrase(w) for w in param.off_words), *negated], stemmed):
                args[param.name] = False
            elif on is not None and not inside:  # "allow mixing" = allow mixed
                args[param.name] = True

    def _text(self, info: CommandInfo, text: str, saved: list[str], raw: str, words: str, args: dict[str, Any]) -> None:
        """Free text: a description, an asset, what to list tasks about, named strings."""
        if "description" in info.params and is_empty(args.get("description")):
            said = text
            for path in saved:  # "... and save it to x.yaml" is not part of the description
                said = re.sub(rf"[,;]?\s*(?:and\s+)?\b(?:save|write|store)s?\b[^,;]*?{re.escape(path)}\S*", "", said)
            sentences = re.split(r"(?<=[.!?;])\s+", said.strip())
            while len(sentences) > 1 and self._only_options(info, sentences[-1]):  # "... stirrer. check it"
                sentences.pop()
            said = " ".join(sentences)
            quoted = _QUOTED.search(said)
            cues = self.vocab.intents.get(info.name, None)
            cue = find_phrase([*cues.phrases, *cues.verbs], said.lower()) if cues else None
            rest = said[cue.end() :] if cue else said
            rest = re.sub(r"^[\s\-—:,.]*(?:(?:where|in which|which|that|so that|for|to|of|:)\s+)?", "", rest)
            rest = re.sub(r"^(?:please|kindly)\b[\s:,.-]*", "", rest, flags=re.IGNORECASE)  # "new task please: ..."
            if quoted or rest.strip(" ."):
                args["description"] = quoted.group(1) if quoted else rest.strip(" .")
        if "about" in info.params and is_empty(args.get("about")):
            about = self.index.filter_words(words)
            if about:
                args["about"] = " ".join(about)
        for param in info.params.values():  # "the microplate reader", "beaker_50ml, beaker_100ml and ..."
            if param.takes_assets and is_empty(args.get(param.name)):
                # an optional one only by an id written out ("with cryovial_5ml as the main object")
                assets = self.assets_in(words) if param.required or param.multiple else self.ids_in(words)
                if assets:
                    args[param.name] = assets if param.multiple else assets[0]
        for param in info.params.values():
            if (
                param.kind != "str"
                or param.values()
                or param.name in self.vocab.values  # named by its values' words ("lighting only"), never the next word
                or not is_empty(args.get(param.name))
                or param.takes_assets
                or param.name in ("description", "about", "backend", "model", "base_url")
            ):
                continue
            pattern = "|".join(phrase_pattern(n).pattern for n in param.names)
            # a value of another option ("the act backbone weights": the policy) is never this one's
            stop = {
                *self.vocab.tasks.stop,
                *self.vocab.filler,
                *(v.lower() for p in info.params.values() for v in p.values()),
            }
            m = re.search(rf"(?:{pattern})\s*(?:=|:|is|of|as|to)?\s*(\"[^\"]+\"|'[^']+'|[^\s,;]+)", raw, re.IGNORECASE)
            if not m or m.group(1).lower() in stop:  # "in the mylab namespace": the value before its name
                m = re.search(rf"\b(?:the|a|an)\s+([\w-]+)\s+(?:{pattern})(?![\w-])", raw, re.IGNORECASE)
            if m and m.group(1).lower() not in stop:
                args[param.name] = m.group(1).strip("\"'")

    def _unknown_task(self, path: str, problems: list[str] | None) -> bool:
        """Whether ``path`` is a task id no task has ("pipette/CloseIncubatorDoor-v1"): said as
        such (added to ``problems``, raised without it), never taken for a file."""
        if not names_no_file(path):
            return False
        try:
            self.registry.get(path)
        except TaskNotFound as exc:
            if problems is None:
                raise AgentError(str(exc)) from exc
            problems.append(str(exc))
        return True

    def _only_options(self, info: CommandInfo, sentence: str) -> bool:
        """Whether ``sentence`` says nothing but options of ``info`` ("check it", "and write it to x")."""
        named = {w for p in info.params.values() if p.name != "description" for w in option_words(p)}
        said = [w for w in words_of(sentence).split() if w not in self.vocab.filler]
        return bool(said) and all(singular(w) in named for w in said)

    def ids_in(self, words: str) -> list[str]:
        """The asset ids ``words`` writes out, in order."""
        longest_first = sorted(load_asset_words().assets, key=len, reverse=True)
        ids = "|".join(map(re.escape, longest_first))
        return list(dict.fromkeys(re.findall(rf"(?<![\w-])(?:{ids})(?![\w-])", words)))

    def assets_in(self, words: str) -> list[str]:
        """The asset ids ``words`` writes out, in order; else each kind it names: every asset of a
        kind named in the plural ("the beakers"), the kind's default asset otherwise."""
        assets = load_asset_words()
        explicit = (
            self.ids_in(words)
            or [  # "microplate reader": microplate_reader
                a for a in sorted(assets.assets, key=len, reverse=True) if a in words.replace(" ", "_")
            ][:1]
        )
        if explicit:
            return explicit
        named: list[str | None] = []
        for name, kind in assets.names_in(words):
            written = words[name.span[0] : name.span[1]]
            plural = singular(written.split()[-1]) != written.split()[-1]
            named += assets.members(kind) if plural else [assets.kinds[kind].default]
        return list(dict.fromkeys(a for a in named if a))
