"""A request -> its clauses, one per command, and which command each clause asks for.

Chained requests ("record 20 demos of X, augment them, convert and train ACT") are split at
the vocabulary's chain words ("then", "after that", ...), at ";" and at sentence ends, and at
"," and "and" when what follows asks for a command of its own (a verb such as "augment");
anything else after them stays in the clause ("..., 64 px images", "pick and place").

A clause's command is the one whose cues (vocabulary ``intents``) weigh most: phrases 3,
verbs 2, nouns 1, and the agent's answers 1 more when the clause is a question. On a tie the
command listed first in the vocabulary wins.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pipette_cli.agent.catalog import CommandCatalog
from pipette_cli.agent.mentions import find_mentions
from pipette_cli.agent.vocabulary import WEIGHTS, VocabularySpec, find_phrase, phrase_pattern

ANSWER_PREFIX = "answer "
RECIPE_PREFIX = "recipe: "
"""A clause's command for a whole workflow (vocabulary ``recipes``): ``recipe: compare augmentation``."""


_CONTRACTIONS = [
    (re.compile(r"\b(what|how|it|that|there|where|who|here)'s\b"), r"\1 is"),
    (re.compile(r"\blet's\b"), "let us"),
    (re.compile(r"n't\b"), " not"),
    (re.compile(r"'ll\b"), " will"),
    (re.compile(r"'re\b"), " are"),
    (re.compile(r"'ve\b"), " have"),
    (re.compile(r"\bi'm\b"), "i am"),
    (re.compile(r"\b(i|we|you)'d\b"), r"\1 would"),
]


def words_of(text: str) -> str:
    """Lowercased words for cue matching: contractions spelled out ("what's" -> "what is"),
    punctuation other than ``' - . + %`` turned into spaces."""
    lowered = text.lower().replace("’", "'").replace("“", '"').replace("”", '"')
    for pattern, spelled in _CONTRACTIONS:
        lowered = pattern.sub(spelled, lowered)
    return " ".join(re.sub(r"[^\w'.+%π-]+", " ", lowered).split()).replace(" .", " ").rstrip(".")


@dataclass(frozen=True)
class Clause:
    text: str
    """The clause as written (paths included)."""
    command: str | None
    score: int
    after: str = "strong"
    """What separates it from the clause before: ``strong`` (a chain word such as "then", or
    the request's start), ``sentence`` or ``weak`` ("," or "and")."""


class Intents:
    """Scores clauses against the vocabulary's command cues."""

    def __init__(self, vocab: VocabularySpec, catalog: CommandCatalog, task_names: list[str]) -> None:
        self.vocab = vocab
        self.names = task_names
        commands = set(catalog.commands)
        filler = set(vocab.filler)
        self.option_words = {  # an option's own words and the words of its multi-word names ("render profile")
            name: {
                w
                for p in info.params.values()
                for n in (p.name.replace("_", " "), *(n for n in p.names if " " in n))
                for w in n.split()
                if w not in filler
            }
            for name, info in catalog.commands.items()
        }
        self.cues = [
            (command, WEIGHTS[kind], phrase)
            for command, cues in vocab.intents.items()
            if command in commands
            for kind in ("phrases", "verbs", "nouns")
            for phrase in getattr(cues, kind)
        ]
        recipes = [
            (f"{RECIPE_PREFIX}{name}", WEIGHTS["phrases"] + 1, cue)
            for name, r in vocab.recipes.items()
            for cue in r.cues
        ]
        self.cues = recipes + self.cues  # a workflow asked for as a whole outweighs any one of its commands
        self.order = [f"{RECIPE_PREFIX}{name}" for name in vocab.recipes] + [c for c in vocab.intents if c in commands]

    def scores(self, text: str) -> dict[str, int]:
        """Command -> cue weight for ``text`` (paths and addresses do not count)."""
        words = words_of(find_mentions(text, self.names).words)
        question = bool(find_phrase(self.vocab.questions, words)) and (
            phrase_pattern(self.vocab.questions[0]).match(words) is not None or text.rstrip().endswith("?")
        )
        out: dict[str, int] = {}
        for command, weight, phrase in self.cues:
            if phrase_pattern(phrase).search(words):
                out[command] = max(out.get(command, 0), weight) + (1 if command in out else 0)
        if question:
            for command in out:
                if command.startswith(ANSWER_PREFIX):
                    out[command] += 1
        return out

    def cue_words(self, text: str, command: str) -> set[str]:
        """The words of ``text`` that ask for ``command``."""
        words = words_of(find_mentions(text, self.names).words)
        spans = [
            m.group(0)
            for c, _, phrase in self.cues
            if c == command
            for m in [phrase_pattern(phrase).search(words)]
            if m
        ]
        return {w for span in spans for w in span.split()}

    def cue_tokens(self, text: str, command: str) -> set[str]:
        """The first and last word of each cue of ``command`` in ``text`` ("record", "grab ...
        demonstrations"): words that ask for the command, not for a task."""
        words = words_of(find_mentions(text, self.names).words)
        spans = [
            m.group(0).split()
            for c, _, phrase in self.cues
            if c == command
            for m in [phrase_pattern(phrase).search(words)]
            if m
        ]
        return {w for span in spans for w in (span[0], span[-1])}

    def best(self, text: str) -> tuple[str | None, int]:
        scores = self.scores(text)
        if not scores:
            return None, 0
        top = max(scores.values())
        return next(c for c in self.order if scores.get(c) == top), top


_SENTENCE = r"[;!?]\s*(?=\S)|\.\s+(?=[A-Za-z])"


def split_clauses(text: str, intents: Intents) -> list[Clause]:
    """The clauses of ``text``, each with its command (None if it names none)."""
    strong = "|".join(phrase_pattern(p).pattern for p in intents.vocab.chain.strong)
    pattern = re.compile(
        rf"(?P<strong>(?:,\s*|\s+and\s+|\s+)(?:{strong})[\s,:]*)|(?P<sentence>{_SENTENCE})"
        rf"|(?P<weak>,\s+|\s+and\s+)",
        re.IGNORECASE,
    )
    pieces: list[tuple[str, str, str]] = []  # (kind of the separator before, the separator, text)
    position, kind, separator = 0, "strong", ""
    for m in pattern.finditer(text):
        pieces.append((kind, separator, text[position : m.start()]))
        kind, separator, position = m.lastgroup or "weak", m.group(0), m.end()
    pieces.append((kind, separator, text[position:]))
    merged: list[list] = []  # [text, command]
    for kind, separator, piece in pieces:
        if not piece.strip():
            continue
        command, score = intents.best(piece)
        # after a chain word any command starts a step; after a sentence end only a verb; after "," or
        # "and" only a verb of another command ("export a.h5 and b.h5 to lerobot" is one step), and not
        # when it names an option of the command before ("augment ... and write the yield report to x")
        previous = merged[-1][1] if merged else None
        starts = command is not None and (
            kind == "strong"
            or previous is None
            or (
                score >= WEIGHTS["verbs"]
                and (kind == "sentence" or command != previous)
                and not intents.cue_words(piece, command) & intents.option_words.get(previous, set())
            )
        )
        if merged and not (starts and merged[-1][1] is not None):
            merged[-1][0] += separator + piece
            merged[-1][1] = merged[-1][1] or command or intents.best(merged[-1][0])[0]
        else:
            merged.append([piece, command, kind if merged else "strong"])
    clauses = []
    for clause_text, command, after in merged:  # a clause keeps the command of the piece that started it
        clause_text = clause_text.strip(" ,;")
        best, score = intents.best(clause_text)
        if best is not None and best.startswith(RECIPE_PREFIX):
            command = best  # "train X with and without augmentation": the workflow, not its first command
        clauses.append(Clause(clause_text, command or best, score, after))
    return clauses
