"""Which registered task a request means, from the registry's own words.

Each task is described by terms with weights: its name's words (1.0), the asset kinds of its
objects as the asset library names them (1.0; "falcon tube" is a conical tube), its category,
tags and robot (0.7), and its instruction's words (0.4). A request's words are stemmed and
mapped through the vocabulary's synonyms ("shut" -> close, "scale" -> balance); each shared
term adds ``weight x idf`` (terms many tasks share count less), and a small bonus for how much
of the task's name (as written) the request covers breaks ties toward the task named most
completely. A task doing the opposite of the request's action (vocabulary ``tasks.opposites``) is
never chosen; where several tasks tie and none of them does the request's action ("open the
incubator door": one incubator task places a dish, the other removes it), none is. An explicit id or
name always wins; equal best scores are reported as ambiguous, never guessed.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field
from functools import cached_property

from pipette_cli.agent.vocabulary import WorkflowVocabularySpec
from pipette_cli.errors import suggest
from pipette_cli.language.assets import load_vocabulary as load_asset_words
from pipette_cli.language.lexicon import camel_words, short_name, stem
from pipette_cli.language.phrases import find_phrase, plain
from pipette_cli.registry import Registry

WEIGHTS = {"name": 1.0, "kind": 1.0, "tag": 0.7, "instruction": 0.4}
ACTIONS = {"pick", "place", "remove", "open", "close", "press", "insert", "position", "transfer"}
"""Action words weigh half an object's: "close the lid" names many tasks, "the incubator" few."""


def _longest_run(name: list[str], words: list[str], holding: AbstractSet[str] | None = None) -> int:
    """Length of the longest run of ``name``'s words that ``words`` repeat in order
    ("tube on balance" in PlaceTubeOnBalance: 3); with ``holding``, of the runs holding one of
    those words only."""
    best = 0
    for i in range(len(words)):
        for j in range(len(name)):
            k = 0
            while i + k < len(words) and j + k < len(name) and words[i + k] == name[j + k]:
                k += 1
            if holding is None or set(words[i : i + k]) & holding:
                best = max(best, k)
    return best


NEW_NAME = ("id", "named", "called", "name")
"""Words before a name something is to get ("draft a task ..., id mylab/X-v1"): not a task's name."""

INSTRUCTION_RUN = 3
"""Words of a task's instruction a request must repeat in a row to pick it among tied tasks."""

_COMPOUND = re.compile(r"(?<![\w-])[a-z0-9]+(?:-[a-z0-9]+){2,}(?![\w-])")
"""Three or more words joined by hyphens ("the dish-out-of-the-incubator scene"): read as words,
where two ("pick-up", "fine-tune") stay one."""


def _unhyphenated(text: str) -> str:
    return _COMPOUND.sub(lambda m: m.group(0).replace("-", " "), text)


def task_in_file_name(path: str, task_ids: list[str]) -> str | None:
    """The registered task whose name a file name holds (``data/PickUpTestTube_augmented.h5``),
    the longest such name if several."""
    name = re.sub(r"[^a-z0-9]", "", path.rsplit("/", 1)[-1].lower())
    named = [tid for tid in task_ids if short_name(tid).lower() in name]
    return max(named, key=lambda tid: len(short_name(tid))) if named else None


@dataclass(frozen=True)
class TaskMatch:
    """A request's task: ``task`` (an id), or ``candidates`` when several fit equally well."""

    task: str | None
    candidates: tuple[str, ...] = ()
    explicit: tuple[str, ...] = ()
    """Ids or names written out in the request, in order."""
    opposed: tuple[str, ...] = ()
    """Tasks about what the request names that do the opposite of its action ("open the
    spectrophotometer" when only CloseSpectrophotometerLid exists): never chosen."""
    action: str = ""
    """The request's action the ``opposed`` tasks undo ("open"), or that the ``other`` tasks lack."""
    other: tuple[str, ...] = ()
    """The tasks about what the request names when none of them does its action ("open the
    incubator door" when the incubator's tasks place and remove a dish): never chosen."""


@dataclass
class TaskIndex:
    """Term weights of every registered task (see the module docstring)."""

    registry: Registry
    vocab: WorkflowVocabularySpec
    terms: dict[str, dict[str, float]] = field(default_factory=dict)
    name_terms: dict[str, set[str]] = field(default_factory=dict)
    name_words: dict[str, list[str]] = field(default_factory=dict)
    said_words: dict[str, list[str]] = field(default_factory=dict)
    """Each task's instruction, word by word (stemmed): "off the balance" is said by one task only."""

    def __post_init__(self) -> None:
        assets = load_asset_words()
        for tid in self.registry.ids():
            spec = self.registry.get(tid)
            terms: dict[str, float] = {}

            def add(words: list[str], kind: str) -> None:
                for w in self.concepts(" ".join(words)):
                    weight = WEIGHTS[kind] * (0.5 if w in self._actions else 1.0)
                    terms[w] = max(terms.get(w, 0.0), weight)  # noqa: B023  (called at once, in this iteration)

            names = camel_words(short_name(tid))
            add(names, "name")
            add(
                [
                    spec.category.replace("_", " "),
                    *(t.replace("-", " ").replace("_", " ") for t in spec.tags),
                    spec.embodiment.robot.replace("_", " "),
                ],
                "tag",
            )
            add(re.findall(r"[a-z0-9]+", spec.instruction.lower()), "instruction")
            for obj in spec.scene.objects:
                info = assets.assets.get(obj.asset)
                for kind in info.kinds if info else ():
                    terms[f"kind:{kind}"] = WEIGHTS["kind"]
            self.terms[tid] = terms
            self.name_terms[tid] = self.concepts(" ".join(names)) - self._stop
            self.name_words[tid] = [stem(w) for w in names]
            self.said_words[tid] = [stem(w) for w in re.findall(r"[a-z0-9]+", spec.instruction.lower())]
        self._assets = assets
        self._aliases = assets.aliases()
        self._alias_kind = assets.alias_to_kind

    @cached_property
    def _stop(self) -> set[str]:
        return {stem(w) for w in self.vocab.tasks.stop}

    @cached_property
    def _actions(self) -> set[str]:
        return {stem(w) for w in ACTIONS}

    def names_a_task(self, text: str) -> bool:
        """Whether ``text`` names a task itself, not only what it uses: a task's name or an action,
        or words of one task's instruction around a relation ("tube off the balance")."""
        if self.explicit(text) or self.request_terms(text) & self._actions:
            return True
        return self._said_by(text, self.registry.ids()) is not None

    def _said_by(self, text: str, tasks: list[str]) -> str | None:
        """The one of ``tasks`` whose instruction ``text`` repeats most, by at least
        :data:`INSTRUCTION_RUN` words in a row around a relation ("tube off the balance"), else None."""
        words = [stem(w) for w in re.findall(r"[a-z0-9]+", _unhyphenated(plain(text)))]
        relations = {stem(w) for w in self.vocab.tasks.relations}
        runs = {t: _longest_run(self.said_words[t], words, relations) for t in tasks}
        longest = max(runs.values(), default=0)
        if longest < INSTRUCTION_RUN or list(runs.values()).count(longest) != 1:
            return None
        return max(runs, key=lambda t: runs[t])

    @cached_property
    def _action_word(self) -> dict[str, str]:
        """An action's stem -> the word said in refusals ("clos" -> "close")."""
        opposites = [w for pair in self.vocab.tasks.opposites.items() for w in pair]
        return {stem(w): w for w in [*ACTIONS, *opposites]}

    @cached_property
    def _synonyms(self) -> list[tuple[re.Pattern[str], str]]:
        """(phrase, canonical word), longest phrase first."""
        pairs = [(syn.lower(), word) for word, syns in self.vocab.tasks.synonyms.items() for syn in syns]
        pairs.sort(key=lambda p: -len(p[0]))
        return [(re.compile(rf"(?<![\w-]){re.escape(s)}(?![\w-])"), w) for s, w in pairs]

    @cached_property
    def _idf(self) -> dict[str, float]:
        df: dict[str, int] = {}
        for terms in self.terms.values():
            for t in terms:
                df[t] = df.get(t, 0) + 1
        n = max(len(self.terms), 1)
        return {t: math.log(1 + n / d) for t, d in df.items()}

    def synonyms(self) -> list[tuple[re.Pattern[str], str]]:
        """(phrase pattern, the word it stands for), longest phrase first."""
        return self._synonyms

    def aliases_of(self, task: str) -> list[str]:
        """The asset library's names for the objects of ``task`` ("falcon tube")."""
        kinds = {t.removeprefix("kind:") for t in self.terms.get(task, {}) if t.startswith("kind:")}
        return [alias for alias in self._aliases if self._alias_kind[alias] in kinds]

    @cached_property
    def _joined(self) -> dict[str, str]:
        """Two adjacent words of a task's name written as one -> said apart ("pickup" -> "pick up",
        "testtube", "waterbath"), unless that is a word of a name itself ("microtube")."""
        names = [[w.lower() for w in camel_words(short_name(t))] for t in self.registry.ids()]
        words = {w for name in names for w in name}
        return {a + b: f"{a} {b}" for name in names for a, b in itertools.pairwise(name) if a + b not in words}

    @cached_property
    def _joined_pattern(self) -> re.Pattern[str] | None:
        """One pattern for every :attr:`_joined` word, longest first (built once: :meth:`concepts` runs per
        task at start and per request)."""
        joined = "|".join(sorted(map(re.escape, self._joined), key=len, reverse=True))
        return re.compile(rf"(?<![\w-])({joined})(?![\w-])") if joined else None

    def _apart(self, text: str) -> str:
        """``text`` with :attr:`_joined` words said apart ("the pickup task" -> "the pick up task")."""
        pattern = self._joined_pattern
        return pattern.sub(lambda m: self._joined[m.group(1)], text) if pattern is not None else text

    def concepts(self, text: str) -> set[str]:
        """Stems of ``text``'s words after the vocabulary's synonyms, stop words left out; two words of a
        task's name written as one are read apart ("pickup")."""
        lowered = self._apart(_unhyphenated(text.lower()))
        for pattern, word in self._synonyms:
            lowered = pattern.sub(f" {word} ", lowered)
        sized = {f"{n}{u}" for n, u in re.findall(r"\b(\d+)\s*(ml|ul|l|mm|cm)\b", lowered)}  # "50 mL": 50ml
        return ({stem(w) for w in re.findall(r"[a-z0-9]+", lowered)} | sized) - self._stop

    def request_terms(self, text: str) -> set[str]:
        """Concepts and asset kinds (``kind:conical tube``) a request names."""
        lowered, names = self._take_names(text, every=True)
        return self.concepts(lowered) | {f"kind:{kind}" for _, kind in names}

    def unmatched_work(self, text: str) -> str:
        """The work a request describes as its task ("demos of opening the autoclave door": from the
        action after "of"/"for", six words at most) when no task matches it; else ""."""
        if self.match(text).task or not self.request_terms(text) & self._actions:
            return ""
        for m in re.finditer(r"\b(?:of|for)\s+(?:the\s+|a\s+|an\s+)?([a-z][\w-]*)", plain(text)):
            if self.concepts(m.group(1)) & self._actions:
                return " ".join(text[m.start(1) :].split()[:6]).rstrip(" ,.;:!?")
        return ""

    def explicit(self, text: str) -> list[str]:
        """Task ids and names written out in ``text`` ("PickUpTestTube", "pick up test tube"),
        in the order they appear."""
        lowered = text.lower()
        squashed = re.sub(r"[^a-z0-9]+", "", lowered)
        found: list[tuple[float, str]] = []
        for tid in self.registry.ids():
            short = short_name(tid).lower()
            for needle in (tid.lower(), tid.split("/", 1)[1].lower(), short):
                m = re.search(rf"(?<![\w/]){re.escape(needle)}(?!\w)", lowered)
                if m:
                    found.append((m.start() / max(len(lowered), 1), tid))
                    break
            else:
                if len(short) > 10 and short in squashed:  # "pick up test tube"
                    found.append((squashed.index(short) / max(len(squashed), 1), tid))
        return [tid for _, tid in sorted(found)]

    def unknown_name(self, text: str) -> str | None:
        """A CamelCase word that looks like a task name but is none ("PickUpTestTub"); policy
        names (SmolVLA, VQ-BeT) and names of other things ("the SmolVLM2 backbone", words of the
        vocabulary's ``refers`` but a task's) are not task names."""
        known = {short_name(t).lower() for t in self.registry.ids()}
        policies = {w for w, _ in self.vocab.policy_words()}
        things = {w for kind, said in self.vocab.refers.items() if kind != "task" for w in said if w.isalpha()}
        tools = {w.lower() for w in self.vocab.filler}  # "MuJoCo", "LeRobot": the tools', never a task's
        for m in re.finditer(r"(?<![\w-])(?:[a-z]+/)?[A-Z][a-z0-9]+(?:[A-Z][a-z0-9]*)+(?:-v\d+)?\b", text):
            token = m.group(0)
            if next(iter(text[m.end() :].lower().split()), "") in things:  # "the SmolVLM2 backbone": a model's name
                continue
            if token.lower() in tools or token.lower() in things:
                continue
            before = text[: m.start()].lower().split()[-1:]
            if before and before[0].strip(":=") in NEW_NAME:  # "id mylab/RackConical15-v1": the name to give
                continue
            word = re.match(r"[\w-]*", text[m.start() :]).group(0).lower()  # type: ignore[union-attr]  # [\w-]* always matches
            if short_name(token).lower() not in known and token.lower() not in policies and word not in policies:
                return token
        return None

    def scores(self, text: str) -> dict[str, float]:
        """Each task's score for ``text`` (tasks sharing no object term are left out)."""
        said = self.request_terms(text)
        request_words = [stem(w) for w in re.findall(r"[a-z0-9]+", text.lower())]
        out: dict[str, float] = {}
        for tid, terms in self.terms.items():
            shared = said & terms.keys()
            if not any(terms[t] > WEIGHTS["instruction"] for t in shared - self._actions):
                continue  # an object, tag or robot must match, not only an action or the instruction
            score = sum(terms[t] * self._idf[t] for t in shared)
            # the name as written: "balance" names PlaceTubeOnBalance, not TareAndWeigh ("weigh")
            names = set(self.name_words[tid]) - self._stop
            run = _longest_run(self.name_words[tid], request_words)
            covered = len(names & said) / max(len(names), 1)
            out[tid] = score + 0.2 * covered + 0.3 * max(run - 1, 0)
        return out

    def match(self, text: str) -> TaskMatch:
        """The task ``text`` names (see the module docstring)."""
        explicit = self.explicit(text)
        if explicit:
            return TaskMatch(explicit[0], (), tuple(explicit))
        scores = self.scores(text)
        terms = self.request_terms(text)
        said = terms & self._actions
        opposed = {tid for tid in scores if self._opposes(tid, said)}
        highest = max(scores.values(), default=0.0)
        leading = {tid for tid in opposed if scores[tid] >= highest - 1e-9}
        objects = {t for t in terms if t.startswith("kind:") and any(t in self.terms[o] for o in leading)}
        scores = {  # where an opposed task led, one left must be about its objects, not only the robot
            tid: score for tid, score in scores.items() if tid not in opposed and objects <= self.terms[tid].keys()
        }
        if not scores:
            action = next(
                (self._action_word.get(a, a) for a in sorted(said) if any(self._opposes(t, {a}) for t in opposed)), ""
            )
            return TaskMatch(None, opposed=tuple(sorted(opposed)), action=action)
        best = max(scores.values())
        top = sorted(t for t, s in scores.items() if s >= best - 1e-9)
        if len(top) > 1 and said and not any(said & self.terms[t].keys() for t in top):  # one task left is meant
            return TaskMatch(None, other=tuple(top), action=self._action_word.get(min(said), min(said)))
        said_by = self._said_by(text, top) if len(top) > 1 else None  # "the tube off the balance"
        if said_by is not None:
            return TaskMatch(said_by)
        return TaskMatch(top[0]) if len(top) == 1 else TaskMatch(None, tuple(top))

    def _opposes(self, task: str, actions: set[str]) -> bool:
        """``task`` (its name, tags or instruction) does the opposite of the request's ``actions``
        and holds none of them (vocabulary ``tasks.opposites``: close for open, remove for place)."""
        if not actions or actions & self.terms[task].keys():
            return False
        undo = {stem(b) for a, b in self.vocab.tasks.opposites.items() if stem(a) in actions}
        undo |= {stem(a) for a, b in self.vocab.tasks.opposites.items() if stem(b) in actions}
        return bool(undo & self.terms[task].keys())

    def describes_work(self, text: str) -> bool:
        """Whether ``text`` names an action a task does and an object of the asset library ("put the
        15 mL tube in the rack"): a description of a task."""
        terms = self.request_terms(text)
        return bool(terms & self._actions) and any(t.startswith("kind:") for t in terms)

    def all_tasks(self, text: str) -> bool:
        """ "all tasks", "every task", "the whole benchmark"."""
        return find_phrase(self.vocab.tasks.all, text.lower()) is not None

    def _strong(self, term: str) -> set[str]:
        """Tasks whose name, tags, robot or objects carry ``term``."""
        return {tid for tid, terms in self.terms.items() if terms.get(term, 0) > WEIGHTS["instruction"]}

    def _take_names(self, text: str, every: bool = False) -> tuple[str, list[tuple[str, str]]]:
        """``text``'s words without the multi-word asset names it holds (whole before their
        parts, :meth:`~pipette_cli.language.assets.Vocabulary.names_in`), and those names as
        written with their kinds (``every``: the one-word names too, which stay in the words)."""
        lowered = _unhyphenated(plain(text))
        names: list[tuple[str, str]] = []
        for name, kind in self._assets.names_in(text):
            (start, end), multi = name.span, name.end - name.start > 1
            if multi or every:
                names.append((lowered[start:end], kind))
            if multi:
                lowered = lowered[:start] + " " * (end - start) + lowered[end:]
        return f" {lowered} ", names

    def word_terms(self, text: str) -> list[set[str]]:
        """The terms of each thing ``text`` names: a multi-word asset name, else one word (its
        concept and the asset kind it names); "centrifuge" -> {centrifug, kind:centrifuge}."""
        lowered, named = self._take_names(text)
        groups = [{f"kind:{kind}"} for _, kind in named]
        for synonym, word in self._synonyms:  # "take out" -> remove: one thing named
            if " " in synonym.pattern and synonym.search(lowered):
                groups.append({stem(word)})
                lowered = synonym.sub(" ", lowered)
        for word in re.findall(r"[a-z0-9]+", lowered):
            terms = self.concepts(word) | self._kind_of(word)
            if terms:
                groups.append(terms)
        return groups

    def filter(self, text: str) -> tuple[list[str], list[str]]:
        """Tasks that carry, for every thing ``text`` names that some task's name, tags, robot or
        objects carry, one of its terms (instruction words do not filter; several actions mean
        any of them), and those terms."""
        hits, actions, used = set(self.terms), [], []
        for group in self.word_terms(text):
            tids = set().union(*(self._strong(t) for t in group))
            if not tids and group & self._known:  # a robot or an object no task has: none is about it
                used += sorted(t.removeprefix("kind:") for t in group & self._known)
                hits = set()
            if not tids:
                continue
            used += sorted(t.removeprefix("kind:") for t in group if self._strong(t))
            if group <= self._actions:
                actions.append(tids)
            else:
                hits &= tids
        if actions:
            hits &= set().union(*actions)
        return sorted(hits), sorted(set(used))

    def _kind_of(self, word: str) -> set[str]:
        """``{kind:<kind>}`` when ``word`` (or its singular) names an asset kind, else nothing."""
        kind = self._alias_kind.get(word) or self._alias_kind.get(self._assets.lemma(word))
        return {f"kind:{kind}"} if kind else set()

    def filter_words(self, text: str) -> list[str]:
        """The words of ``text`` that :meth:`filter` uses (object, action, tag or robot words,
        and any robot or object of the libraries, which no task may have)."""
        lowered, named = self._take_names(text)
        out = [written for written, _ in named]
        for word in re.findall(r"[a-z0-9]+", lowered):
            terms = self.concepts(word) | self._kind_of(word)
            if (any(self._strong(t) for t in terms) or terms & self._known) and word not in out:
                out.append(word)
        return out

    @cached_property
    def _known(self) -> set[str]:
        """Terms of the robot and asset libraries (``ur5e``, ``kind:beaker``), whether or not a task has them."""
        from pipette_cli.specs.robot import robot_words  # deferred: the robot facts

        robots = {stem(w) for names in robot_words().values() for name in names for w in re.findall(r"[a-z0-9]+", name)}
        return {f"kind:{kind}" for kind in self._alias_kind.values()} | (robots - self._stop)

    def suggest_name(self, phrase: str) -> str:
        names = [short_name(t) for t in self.registry.ids()]
        return suggest(phrase.replace(" ", ""), names)
