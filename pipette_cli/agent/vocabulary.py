"""The agent's vocabulary (``vocabulary.yaml`` beside this module): how people name commands,
options, values, policies and tasks, as data.

Phrases use a small syntax (see the YAML's header) compiled to regular expressions by
:func:`phrase_pattern`; they are matched against a request's words (lowercased, paths and
addresses already taken out).
"""

from __future__ import annotations

import re
from functools import cache, cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import Field

from pipette_cli.language.lexicon import registry_values
from pipette_cli.language.phrases import phrase_pattern
from pipette_cli.specs.base import Spec
from pipette_cli.specs.yaml_io import read_spec

if TYPE_CHECKING:
    from pipette_cli.registry import Registry

VOCABULARY_FILE = Path(__file__).with_name("vocabulary.yaml")
WEIGHTS = {"phrases": 3, "verbs": 2, "nouns": 1}


ANSWER_PREFIX = "answer "
"""The agent's own answers ("answer demos"), which the vocabulary names like commands but the CLI has not."""


class IntentCuesSpec(Spec):
    """Phrases that ask for one command (weights in :data:`WEIGHTS`)."""

    phrases: list[str] = Field(default_factory=list)
    verbs: list[str] = Field(default_factory=list)
    nouns: list[str] = Field(default_factory=list)


class ChainSpec(Spec):
    strong: list[str]
    """Words that always start a new step ("then", "after that")."""


class OptionWordsSpec(Spec):
    """Words for one parameter: ``units`` follow a number, ``names`` precede one or switch a
    flag on, ``off`` switch a flag off."""

    units: list[str] = Field(default_factory=list)
    names: list[str] = Field(default_factory=list)
    off: list[str] = Field(default_factory=list)


class PolicySpec(Spec):
    name: str
    words: list[str]


class TaskWordsSpec(Spec):
    all: list[str]
    synonyms: dict[str, list[str]]
    stop: list[str]
    opposites: dict[str, str] = Field(default_factory=dict)
    """Actions that undo each other (open: close): a task doing the opposite of what a request
    asks is never chosen for it."""
    relations: list[str] = Field(default_factory=list)
    """Words that say where a thing goes or comes from ("off", "onto"): among tied tasks, the one
    whose instruction repeats a run of the request's words holding one ("tube off the balance")."""


class ProductSpec(Spec):
    """What a command makes: the option naming it (or a rule in :mod:`.products`), its kind, and
    values a step consuming it takes over (an augmented file -> ``dataset_version: augmented``)."""

    param: str | None = None
    kind: str
    sets: dict[str, str] = Field(default_factory=dict)


class RecipeStepSpec(Spec):
    command: str
    args: dict[str, Any] = Field(default_factory=dict)


class RecipeSpec(Spec):
    """A request for a whole workflow ("compare raw and augmented ACT on X"): the cues that ask
    for it and its steps; the request's own words fill every step that takes them."""

    cues: list[str]
    explains: list[str] = Field(default_factory=list)
    """Words the workflow explains without asking for it ("compare")."""
    defaults: dict[str, Any] = Field(default_factory=dict)
    steps: list[RecipeStepSpec] = Field(min_length=1)


RANGE_WORDS = ("to", "through", "thru", "until", "-", "–")
"""What stands between the ends of a range ("seeds 100 to 149", "seeds 0-9")."""


class RangeSpec(Spec):
    """A range of an option's values ("seeds 100 to 149"): its first value and how many (``count``)."""

    count: str
    names: list[str]

    def pattern(self) -> re.Pattern[str]:
        """``<name> A (to|through|-) B``: groups 1 and 2 are A and B."""
        names = "|".join(phrase_pattern(n).pattern for n in self.names)
        between = "|".join(map(re.escape, RANGE_WORDS))
        return re.compile(rf"(?<![\w-])(?:{names})\s+(\d+)\s*(?:{between})\s*(\d+)(?![\w.-])")

    def phrases(self, first: int, last: int) -> list[str]:
        """How the range from ``first`` to ``last`` is said, as vocabulary phrases ("seeds 0-9" is one word)."""
        between = "|".join(RANGE_WORDS)
        return [p for n in self.names for p in (f"{n} {first} ({between}) {last}", f"{n} {first}-{last}")]


class WorkflowVocabularySpec(Spec):
    intents: dict[str, IntentCuesSpec]
    questions: list[str]
    chain: ChainSpec
    options: dict[str, OptionWordsSpec]
    values: dict[str, dict[str, list[str]]]
    numbers: dict[str, int | float]
    bare_number: str
    ordinals: dict[str, int] = Field(default_factory=dict)
    """"third" -> 3: a position, for the parameters in ``from_zero`` ("the third episode" is index 2)."""
    from_zero: list[str] = Field(default_factory=list)
    """Parameters that count from 0 (episode indices)."""
    policies: dict[str, PolicySpec]
    tasks: TaskWordsSpec
    defaults: dict[str, str | list[str]]
    """Command.option -> the output it gets when the request gives none: the first template whose
    names are known (``{Task}``: the task's short name, ``{Suite}``: the suite's)."""
    carry: list[str]
    carry_to: dict[str, list[str]]
    task_params: dict[str, str] = Field(default_factory=dict)
    """Command -> its option that takes a registered task the request names, where the command
    has no task parameter (``tasks new --from``: its positional id is the task it creates)."""
    one_of: dict[str, list[str]]
    background: dict[str, str]
    products: dict[str, ProductSpec]
    consumes: dict[str, str]
    links_optional: list[str] = Field(default_factory=list)
    """``consumes`` keys of optional inputs that still take an earlier step's product when one of
    their kind was made ("copy X into my_tasks/, then validate it": that file, not the registry)."""
    files: dict[str, str] = Field(default_factory=dict)
    """A file suffix -> the kind of thing such a file is (``h5`` -> ``demos``)."""
    stands_in: dict[str, dict[str, str]] = {}
    implies: dict[str, dict[str, dict[str, str]]] = Field(default_factory=dict)
    """Command -> an option -> values of other options it needs, filled in when the request gives
    none (``augment --noise-window`` acts on noise variants only: ``--variants noise``)."""
    contains: dict[str, dict[str, list[str]]] = Field(default_factory=dict)
    """Option -> a value that stands for several -> the values it holds (``--variants paper``: light,
    speed, cam); :attr:`implies` adds none of these to it."""
    uncounted: dict[str, list[str]] = Field(default_factory=dict)
    """Option -> its values a count never repeats (``--variants original``, ``paper``: the CLI refuses
    ``NAME*N`` for them): "the originals and lighting, 3 draws each" is ``original,light*3``."""
    about_an_asset: dict[str, str] = Field(default_factory=dict)
    """Command -> the command its clause asks for when it names an asset and no task ("show me the
    spectrophotometer": ``assets show``, not the one task that uses it)."""
    refers: dict[str, list[str]] = Field(default_factory=dict)
    """A kind of thing (``demos``, ``policy``, ``task``...) -> words that refer to it."""
    explains: dict[str, list[str]] = Field(default_factory=dict)
    """Command -> words its plan explains without asking for the command."""
    each: list[str] = Field(default_factory=list)
    """Words that mean every earlier output of a kind ("convert both")."""
    together: list[str] = Field(default_factory=list)
    """Words that put every earlier output of a kind into one step, where its input takes several
    ("convert both into one dataset"): one step, not one per output."""
    unsupported: dict[str, str] = Field(default_factory=dict)
    """A phrase asking for something no command does -> what to say instead ("push ... to the
    hub": nothing pushes; a plan would do something else quietly)."""
    topics: list[str] = Field(default_factory=list)
    """Words that open a clause saying what the request is about ("for the rack demos in x.h5, make
    ..."): without a verb of its own, such a clause joins the one after it."""
    opening: list[str] = Field(default_factory=list)
    """Words that only open a request ("first, ...")."""
    repeats: list[str] = Field(default_factory=list)
    """Words that ask for the command once more ("again", "another"): such a clause is a step of its own."""
    done_before: list[str] = Field(default_factory=list)
    """Words that, with a command's cue alone ("after training"), say what was done before."""
    corrections: list[str] = Field(default_factory=list)
    """Words that take back what came before ("actually", "no -")."""
    happened: list[str] = Field(default_factory=list)
    """Phrases that report what happened ("... was killed overnight"): such a clause before another
    plans nothing itself; it tells the next one what it is about (its file, its task)."""
    resumes: list[str] = Field(default_factory=list)
    """Phrases that, after a clause reporting what happened, ask for that step again ("...; resume it"):
    they start a clause of their own, which takes its command from the report (every stage resumes)."""
    per_each: list[str] = Field(default_factory=list)
    """Words that say a count is for each input ("per demo"): ``--variants object*3``."""
    number_leads: list[str] = Field(default_factory=list)
    """Words that only lead to a number an option takes ("within 2x the task range", "up to 30 demos")."""
    inputs: list[str] = Field(default_factory=list)
    """Nouns for what a command takes one at a time ("per demo", "for each episode")."""
    combined: list[str] = Field(default_factory=list)
    """Words that ask for several values in one ("lighting and camera jitter together": ``light+cam``)."""
    counts_of: list[str] = Field(default_factory=list)
    """Words between a count and the values it is for ("3 draws each of lighting and camera jitter")."""
    distributes: list[str] = Field(default_factory=list)
    """Nouns that words coordinated before them each take ("object and clutter variants")."""
    ranges: dict[str, RangeSpec] = Field(default_factory=dict)
    """Option -> how a range of its values is said and which option counts it ("seeds 100 to 149")."""
    every: dict[str, list[str]] = Field(default_factory=dict)
    """Option -> words asking for every one of its values ("on each robot"): one step per value."""
    filler: list[str] = Field(default_factory=list)
    """Words that carry no request of their own ("please", "the", "could"): never "not understood"."""
    recipes: dict[str, RecipeSpec] = Field(default_factory=dict)
    """Whole workflows asked for in a phrase ("compare raw vs augmented ...")."""

    def words_for(self, param: str, command: str = "") -> OptionWordsSpec:
        """Words for ``param`` of ``command`` (a ``command.param`` entry wins over ``param``)."""
        return self.options.get(f"{command}.{param}") or self.options.get(param, OptionWordsSpec())

    def consumed(self, command: str) -> dict[str, str]:
        """The options of ``command`` that read an earlier step's product -> the kind each reads
        (``consumes``' ``command.option`` keys)."""
        return {
            option: kind
            for key, kind in self.consumes.items()
            for owner, _, option in [key.rpartition(".")]
            if owner == command
        }

    def file_inputs(self, command: str) -> set[str]:
        """The options of ``command`` that read a kind of file named by its suffix (``data video``'s
        ``file``: an ``.h5`` file of demos): a folder is never their value."""
        kinds = set(self.files.values())
        return {option for option, kind in self.consumed(command).items() if kind in kinds}

    def readers(self) -> dict[str, list[str]]:
        """A file suffix -> the commands that read that kind of file, those that turn it into
        something else first (``h5`` -> convert, augment, data inspect, ...)."""

        def order(command: str, kind: str) -> tuple[bool, bool]:
            made = self.products.get(command)
            return (made is None or made.kind == kind, " " in command)

        out = {}
        for suffix, kind in self.files.items():
            commands = dict.fromkeys(
                key.rsplit(".", 1)[0]
                for key, k in self.consumes.items()
                if k == kind and not key.startswith(ANSWER_PREFIX)  # only commands a user can run
            )
            out[suffix] = sorted(commands, key=lambda c: order(c, kind))
        return out

    @cached_property
    def spelled(self) -> dict[str, int | float]:
        """The number words and the compounds of their tens and units: "twenty-five", "twenty five"
        -> 25 (built once per vocabulary)."""
        out = dict(self.numbers)
        tens = {w: n for w, n in self.numbers.items() if " " not in w and n in range(20, 100, 10)}
        units = {w: n for w, n in self.numbers.items() if " " not in w and n in range(1, 10)}
        for ten, t in tens.items():
            for unit, u in units.items():
                out[f"{ten}-{unit}"] = out[f"{ten} {unit}"] = t + u
        return out

    def policy_words(self) -> list[tuple[str, str]]:
        """(word, policy) pairs, longest word first ("pi0.5" before "pi0")."""
        pairs = [(w.lower(), key) for key, p in self.policies.items() for w in [key, *p.words]]
        return sorted(set(pairs), key=lambda pair: -len(pair[0]))


@cache
def load_vocabulary(path: Path = VOCABULARY_FILE) -> WorkflowVocabularySpec:
    """Read and validate the vocabulary file.

    Raises:
        SpecError: ``file:line: field: message`` for each problem.
    """
    return read_spec(path, WorkflowVocabularySpec)


def lexicon(registry: Registry) -> WorkflowVocabularySpec:
    """The vocabulary with the registries' words added as values
    (:func:`pipette_cli.language.lexicon.registry_values`: every robot's names as ``robot``,
    every suite's as ``suite_id``)."""
    vocab = load_vocabulary()
    return vocab.model_copy(update={"values": {**vocab.values, **registry_values(registry)}})


def distributed(text: str, nouns: list[str]) -> str:
    """``text`` with words coordinated before one of ``nouns`` each given it: "light, cam and
    object variants" -> "light variants, cam variants and object variants"."""
    if not nouns:
        return text
    pattern = re.compile(
        r"(?<![\w-])([a-z][\w-]*(?:,\s*[a-z][\w-]*)*)(,?\s+(?:and|or|&)\s+)([a-z][\w-]*)\s+"
        rf"({'|'.join(map(re.escape, nouns))})(?![\w-])",
        re.IGNORECASE,
    )

    def spread(m: re.Match[str]) -> str:
        items = re.split(r",\s*", m.group(1))
        return ", ".join(f"{item} {m.group(4)}" for item in items) + f"{m.group(2)}{m.group(3)} {m.group(4)}"

    return pattern.sub(spread, text)
