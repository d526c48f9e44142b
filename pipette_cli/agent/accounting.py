"""Every word of a request accounted for: the words a checked plan uses, and those it does not.

Whoever wrote the plan (the offline parser or an LLM), a word of the request is *used* when the
plan explains it:

* it is a function word (vocabulary ``filler``), a chain word ("then"), a question word of a
  plan that answers, or part of a command cue of a command the plan runs (the literal words of
  the cue, never the gap of a ``...`` phrase);
* it names a task the plan uses (the task's name, tags, robot, instruction and its objects' asset
  names, through the registry index and the vocabulary's synonyms);
* it names a value the plan holds: a number equal to an argument (written or spelled, "64x64",
  "15k") with the words of that option, a value's words (vocabulary ``values``, CLI choices, the
  value itself, a policy's names, a robot's names), a flag's words, or it lies inside free text
  the plan carries (a description, what to list tasks about);
* it tells, after the event of a clause reporting what happened, how far or why ("... died at
  step 9000 when the node rebooted; resume it"), and asks for nothing itself.

Anything else is *not understood* and listed in the request's order (:func:`unused_words`); a
plan with such words is shown with them and never run without asking.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from pipette_cli.agent.catalog import TASK_PARAMS, CommandCatalog, ParamInfo
from pipette_cli.agent.mentions import SAVE_VERBS, option_words
from pipette_cli.agent.numbers import (
    TIME_UNITS,
    control_rate,
    durations,
    in_control_steps,
    in_metres,
    length_phrases,
)
from pipette_cli.agent.plan import CheckedPlan, StepRef
from pipette_cli.agent.tasks import TaskIndex
from pipette_cli.agent.vocabulary import ANSWER_PREFIX, RecipeSpec, WorkflowVocabularySpec, distributed
from pipette_cli.errors import PipetteError
from pipette_cli.language.assets import load_vocabulary as load_asset_words
from pipette_cli.language.clauses import LIST_MARK, Separators, pieces
from pipette_cli.language.lexicon import short_name, stem
from pipette_cli.language.mentions import find_mentions
from pipette_cli.language.phrases import find_phrase, phrase_pattern, phrase_tokens, words_of

FREE_TEXT = ("description", "about", "name", "asset_id")
"""Parameters whose value is the request's own words."""
_NUMBER = re.compile(r"^-?\d+(?:,\d{3})*(?:\.\d+)?(k)?(%)?$")
_SIZE = re.compile(r"^(\d+)[x×](\d+)$")
_GLUED = re.compile(r"^(\d+(?:\.\d+)?k?)-?([a-z]+)$")
SAVE_VERB = re.compile(rf"(?:{SAVE_VERBS})[sd]?|saved|written|stored|wrote|writing|saving|storing")


def _suffix(n: int) -> str:
    """1 -> st, 2 -> nd, 3 -> rd, 11 -> th."""
    return "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")


def _literals(phrase: str) -> tuple[set[str], tuple[str, ...]]:
    """The literal words of a vocabulary phrase and its ``word*`` prefixes."""
    words: set[str] = set()
    prefixes: list[str] = []
    for token in phrase_tokens(phrase):
        token = token.rstrip("?") if len(token) > 1 else token
        for alt in token.strip("()").split("|"):
            for word in alt.split():
                if word == "...":
                    continue
                if word.endswith("*"):
                    prefixes.append(word[:-1])
                else:
                    words.add(word)
    return words, tuple(prefixes)


def _holds(plan: CheckedPlan, recipe: RecipeSpec) -> bool:
    """Whether the plan's steps include the recipe's, in order, with its fixed values."""
    steps = iter(plan.steps)
    for item in recipe.steps:
        fixed = {k: v for k, v in item.args.items() if isinstance(v, str | int | float) and "{" not in str(v)}
        if not any(s.command == item.command and all(s.args.get(k) == v for k, v in fixed.items()) for s in steps):
            return False
    return True


def _several(value: Any) -> bool:
    """A list of two or more values, or several comma-separated ones."""
    return (isinstance(value, list) and len(value) > 1) or (isinstance(value, str) and "," in value)


@dataclass
class _Words:
    """The request's words (as the parser reads them) and which of them are used."""

    tokens: list[str]
    used: list[bool]

    @classmethod
    def of(cls, text: str, units: set[str]) -> _Words:
        """The words the parser reads of ``text`` (paths and addresses already out); quotes and a
        final full stop taken off, one of ``units`` glued or hyphened to its number set apart ("48px",
        "48-px" -> "48 px"; "15k", "5e", "96-well" stay)."""
        tokens: list[str] = []
        for token in words_of(text).split():
            token = token.strip("'\"").rstrip(".")
            glued = _GLUED.match(token)
            tokens += [glued.group(1), glued.group(2)] if glued and glued.group(2) in units else [token]
        tokens = [t for t in tokens if t]
        return cls(tokens, [False] * len(tokens))

    @property
    def text(self) -> str:
        return " ".join(self.tokens)

    def _index_at(self) -> list[int]:
        """Character offset of each token in :attr:`text`."""
        offsets, at = [], 0
        for token in self.tokens:
            offsets.append(at)
            at += len(token) + 1
        return offsets

    def phrase(self, phrase: str) -> None:
        """Mark the literal words of every match of ``phrase``."""
        words, prefixes = _literals(phrase.lower())
        offsets = self._index_at()
        greedy = re.compile(phrase_pattern(phrase.lower()).pattern.replace("{0,10}?", "{0,10}"))  # the whole span
        for m in greedy.finditer(self.text):
            for i, at in enumerate(offsets):
                token = self.tokens[i]
                if m.start() <= at < m.end() and (token in words or token.startswith(prefixes or ("\0",))):
                    self.used[i] = True

    def where(self, test: Any) -> None:
        """Mark the tokens ``test`` accepts, a possessive by its noun ("PlaceTubeOnBalance's")."""
        for i, token in enumerate(self.tokens):
            if not self.used[i] and (test(token) or (token.endswith("'s") and test(token[:-2]))):
                self.used[i] = True

    def before_used_numbers(self, leads: list[str]) -> None:
        """Mark the words of ``leads`` right before a number that is used ("within 2x the task range")."""
        offsets = self._index_at()
        for phrase in leads:
            for m in re.finditer(rf"{phrase_pattern(phrase.lower()).pattern}(?= )", self.text):
                after = next((i for i, at in enumerate(offsets) if at == m.end() + 1), None)
                if after is not None and self.used[after] and _NUMBER.match(self.tokens[after]):
                    for i, at in enumerate(offsets):
                        self.used[i] = self.used[i] or m.start() <= at < m.end()

    def unused(self) -> list[str]:
        return [t for t, u in zip(self.tokens, self.used, strict=True) if not u]


class Accountant:
    """Says which words of a request a checked plan leaves unexplained."""

    def __init__(self, catalog: CommandCatalog, vocab: WorkflowVocabularySpec, index: TaskIndex) -> None:
        self.catalog = catalog
        self.vocab = vocab
        self.index = index
        self.filler = {w.lower() for w in vocab.filler}
        self.units = {u for info in catalog.commands.values() for p in info.params.values() for u in p.units}
        self.units |= TIME_UNITS  # "0.5-second", "500ms": a duration of an option counted in control steps
        self.units |= {"x", "×"}  # "2x": a factor or a count said as one

    def unused_words(self, request: str, plan: CheckedPlan) -> list[str]:
        """The words of ``request`` that ``plan`` does not explain, in order (see the module docstring)."""
        mentions = find_mentions(request, self.index.registry.ids())
        said = distributed(LIST_MARK.sub(" ", mentions.words), self.vocab.distributes)  # "1) ...": no words
        words = _Words.of(said, self.units)
        words.where(lambda t: t in self.filler or not re.search(r"[a-z0-9]", t))
        if mentions.paths:  # "store them in out/x.h5", "write the augmented file to x.h5"
            words.where(lambda t: SAVE_VERB.fullmatch(t) is not None)
        self._superseded(words)
        for phrase in self.vocab.opening:
            m = phrase_pattern(phrase.lower()).match(words.text)
            if m:
                words.used[: len(m.group(0).split())] = [True] * len(m.group(0).split())
        plain_chain = "|".join(c for c in self.vocab.chain.strong if "(" not in c)
        for phrase in self.vocab.opening:  # "look inside x.h5 first, then ...": said before the chain word
            words.phrase(f"{phrase} ({plain_chain})")
        for phrase in [*self.vocab.chain.strong, *self.vocab.happened]:  # "then"; "... was killed": what happened
            words.phrase(phrase)
        if find_phrase(self.vocab.happened, words.text) is not None:  # "...; resume it": that step again
            for phrase in [*self.vocab.resumes, *self._reports(said)]:
                words.phrase(phrase)
        for kind in self._kinds(plan):
            for phrase in self.vocab.tasks.all if kind == "all tasks" else self.vocab.refers.get(kind, []):
                words.phrase(phrase)
        for recipe in self.vocab.recipes.values():
            if _holds(plan, recipe):  # "compare raw vs augmented": the whole workflow is planned
                for phrase in [*recipe.cues, *recipe.explains]:
                    words.phrase(phrase)
        commands = [s.command for s in plan.steps]
        values = [v for s in plan.steps for v in s.args.values()]
        repeated = len(set(commands)) < len(commands)
        if repeated or any(_several(v) for v in values):
            words.where(lambda t: t == "both")  # two steps of one command, or two values of one option
        if repeated:  # "... and another 15 on the Piper": the command once more
            words.where(lambda t: t in self.vocab.repeats)
        for step in plan.steps:
            info = self.catalog.get(step.command)
            product = self.vocab.products.get(step.command)
            for name, value in product.sets.items() if product else ():  # an augmented file
                for phrase in self.vocab.values.get(name, {}).get(value, []):
                    words.phrase(phrase)
            cues = self.vocab.intents.get(step.command)
            for phrase in [*cues.phrases, *cues.verbs, *cues.nouns] if cues else []:
                words.phrase(phrase)
            for phrase in self.vocab.explains.get(step.command, []):
                words.phrase(phrase)
            if step.command.startswith(ANSWER_PREFIX):
                for phrase in self.vocab.questions:
                    words.phrase(phrase)
            hz = control_rate(self.index.registry, info, step.args)
            for name, value in step.args.items():
                param = info.params.get(name)
                if param is not None:
                    self._value(words, param, value, hz)
                    for word in option_words(param):  # "the same suite": a value taken from the step before
                        words.phrase(f"same {word}")
            for name, spec in self.vocab.ranges.items():  # "seeds 100 to 149": --seed 100 --episodes 50
                first, count = step.args.get(name), step.args.get(spec.count)
                if isinstance(first, int) and isinstance(count, int):
                    for phrase in spec.phrases(first, first + count - 1):
                        words.phrase(phrase)
            if info.task_param() is not None:
                words.phrase("same (task|tasks)")
        words.before_used_numbers(self.vocab.number_leads)
        return words.unused()

    def _reports(self, said: str) -> list[str]:
        """What a clause reporting what happened tells after the event, before another clause asks
        for something ("... died at step 9000 of 15000 when the node rebooted. pick it up": 'at step
        9000 of 15000 when the node rebooted'), as literal phrases: the story of the step, which the
        parser reads no value from (:func:`pipette_cli.agent.clauses.split_clauses`). A tail that
        asks for something itself (a command's verb, "rerun it") is no story and stays accounted."""
        asks = [*self.vocab.resumes, *(v for cues in self.vocab.intents.values() for v in cues.verbs)]
        found = pieces(said, Separators(strong=tuple(self.vocab.chain.strong)))
        tails = []
        for piece in found[:-1]:
            text = words_of(piece.text)
            event = find_phrase(self.vocab.happened, text)
            tail = _Words.of(text[event.end() :], self.units).text if event and "?" not in piece.text else ""
            if tail and find_phrase(asks, tail) is None:
                tails.append(tail)
        return tails

    def _superseded(self, words: _Words) -> None:
        """Words before a correction ("make 3 copies? no - just augment ...") are taken back."""
        for phrase in self.vocab.corrections:
            m = phrase_pattern(phrase.lower()).search(words.text)
            if m:
                upto = len(words.text[: m.end()].split())
                words.used[:upto] = [True] * upto

    def _kinds(self, plan: CheckedPlan) -> set[str]:
        """The kinds of thing the plan makes or reads (``task`` when a step takes one)."""
        kinds: set[str] = set()
        for step in plan.steps:
            product = self.vocab.products.get(step.command)
            if product is not None:
                kinds.add(product.kind)
            kinds |= set(self.vocab.consumed(step.command).values())
            param = self.catalog.get(step.command).task_param()
            copied = self.vocab.task_params.get(step.command)  # `tasks new --from TASK`: a task copied
            if param is not None or step.args.get("suite_id") or (copied and step.args.get(copied) in self.index.terms):
                kinds.add("task")
            if param is not None and not param.required and step.args.get(param.name) in (None, "all"):
                kinds.add("all tasks")  # a command whose tasks default to all of them
        return kinds

    # -- one argument -------------------------------------------------------------------------

    def _value(self, words: _Words, param: ParamInfo, value: Any, control_hz: float) -> None:
        if isinstance(value, list):
            for item in value:
                self._value(words, param, item, control_hz)
            if param.name in self.vocab.from_zero and value == list(range(len(value))) and len(value) > 1:
                counts = [str(len(value)), *(w for w, n in self.vocab.spelled.items() if n == len(value))]
                words.phrase(f"first ({'|'.join(counts)})")  # "the first two episodes": 0 and 1
            return
        if value is None or isinstance(value, StepRef):
            return
        if param.comma_list and isinstance(value, str) and "," in value:  # --variants light,cam
            for item in value.split(","):
                self._value(words, param, item.strip(), control_hz)
            return
        if isinstance(value, str) and (
            (param.name in TASK_PARAMS and param.kind == "task") or value in self.index.terms
        ):
            for task in value.split(","):
                self._task(words, task.strip())
        elif isinstance(value, bool):
            for phrase in param.names if value else (*param.off_words, *param.negated()):
                words.phrase(phrase)
        elif isinstance(value, int | float):
            self._number(words, float(value))
            if in_metres(param):  # "a 3 cm range" for --object-xy 0.03
                for phrase in length_phrases(float(value)):
                    words.phrase(phrase)
            if in_control_steps(param):  # "a 0.5-second window", "half a second" for --noise-window 15 at 30 Hz
                for amount, unit in durations(float(value), control_hz):
                    for spoken in [f"{amount:g}", *(w for w, n in self.vocab.spelled.items() if n == amount)]:
                        words.phrase(f"{spoken} {unit} (long)?")
            if param.name in self.vocab.from_zero:  # "the third episode" is index 2
                position = int(value) + 1
                words.where(lambda t: t == f"{position}{_suffix(position)}")
                for ordinal in (w for w, n in self.vocab.ordinals.items() if n == position):
                    words.phrase(ordinal)
            for phrase in [*param.units, *param.names]:
                words.phrase(phrase)
        elif (
            param.takes_assets
            or param.name in FREE_TEXT
            or (param.kind == "str" and not param.values() and param.name not in self.vocab.values)
        ):
            said = set(words_of(str(value)).split()) | set(words_of(str(value).replace("_", " ")).split())
            words.where(lambda t: t in said or set(t.replace("_", " ").split()) <= said)  # beaker_50ml
            for phrase in param.names:
                words.phrase(phrase)
            if param.takes_assets:
                self._asset_kinds(words, str(value))
        else:
            self._choice(words, param, str(value))

    def _choice(self, words: _Words, param: ParamInfo, value: str) -> None:
        value, _, count = value.partition("*")
        if count:  # --variants object*3: "three object-pose draws (per demo)", "a 3x augmentation"
            self._number(words, float(count))
            for phrase in [*self.vocab.per_each, *self.vocab.counts_of, f"{count} (x|×|times)"]:
                words.phrase(phrase)
        base, _, index = value.partition(":")
        if index and base in param.indexed:  # "cuda:1"
            value = base
            self._number(words, float(index))
        lowered = value.lower()
        phrases = [*self.vocab.values.get(param.name, {}).get(value, []), lowered]
        if param.comma_list and "+" in value:  # "the light+cam variant only"; "lighting and camera jitter together"
            phrases.append(f"{lowered} (variant|variants|perturbation|perturbations)? (only)?")
            for atom in value.split("+"):
                phrases += self.vocab.values.get(param.name, {}).get(atom, [])
            phrases += self.vocab.combined
        phrases += self.vocab.every.get(param.name, [])  # "on each robot": every value, one step each
        if param.name == "suite_id":  # "the paper benchmark with paraphrased instructions": its name's words
            phrases += self._suite_name(value).split()
        if param.kind == "path":  # "the SmolVLM2 backbone from /models/smolvlm2": the folder's name
            phrases += [lowered.rstrip("/").rsplit("/", 1)[-1].rsplit(".", 1)[0]]
        policy = self.vocab.policies.get(lowered)
        if policy is not None:
            phrases += [policy.name.lower(), *policy.words]
        said = {p.lower() for p in phrases}
        words.where(lambda t: t in said)
        for phrase in phrases:
            words.phrase(phrase)
        for phrase in param.names:
            words.phrase(phrase)

    def _suite_name(self, suite: str) -> str:
        """The words of a registered suite's name ("the paper's 12 tasks, paraphrased instructions")."""
        from pipette_cli.evaluation.suites import load_suites  # deferred: suites only when one is planned

        try:
            found = load_suites(self.index.registry).get(suite)
        except PipetteError:
            return ""
        return words_of(found.spec.name) if found is not None else ""

    def _asset_kinds(self, words: _Words, asset: str) -> None:
        """The names of an asset's kinds, in the plural too ("the beakers" for ``beaker_50ml``)."""
        library = load_asset_words()
        info = library.assets.get(asset)
        kinds = set(info.kinds) if info else set()
        for alias, kind in library.alias_to_kind.items():
            if kind in kinds:
                words.phrase(f"{alias}*")

    def _number(self, words: _Words, value: float) -> None:
        spelled = {w for w, n in self.vocab.spelled.items() if n == value}
        thousands = value / 1000 if value and value % 1000 == 0 else None  # "twelve thousand", "12 thousand"
        said = [f"{thousands:g}", *(w for w, n in self.vocab.spelled.items() if n == thousands)] if thousands else []
        for phrase in [*spelled, *(f"{w} thousand" for w in said)]:
            words.phrase(phrase)

        def same(token: str) -> bool:
            m = _NUMBER.match(token)
            if m:
                number = float(token.rstrip("k%").replace(",", "")) * (1000 if m.group(1) else 1)
                return number / (100 if m.group(2) else 1) == value or number == value
            size = _SIZE.match(token)
            if size:
                return float(size.group(1)) == value
            return False

        words.where(same)

    def _task(self, words: _Words, task: str) -> None:
        if task == "all":
            for phrase in self.vocab.tasks.all:
                words.phrase(phrase)
            return
        if task not in self.index.terms:
            return
        names = {task.lower(), *task.lower().split("/"), short_name(task).lower()}
        terms = self.index.terms[task]
        relations = set(self.vocab.tasks.relations) & set(self.index.said_words[task])
        words.where(lambda t: t in relations)  # "tube off the balance": its instruction's "off"
        for pattern, word in self.index.synonyms():
            if stem(word) in terms:
                for m in pattern.finditer(words.text):
                    words.phrase(m.group(0))
        for alias in self.index.aliases_of(task):
            words.phrase(alias)
        words.where(
            lambda t: t in names or bool((self.index.concepts(t) | self.index.concepts(stem(t))) & terms.keys())
        )
