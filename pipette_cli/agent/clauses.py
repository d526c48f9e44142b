"""A request -> its clauses, one per command, and which command each clause asks for.

Chained requests ("record 20 demos of X, augment them, convert and train ACT") are split by the
one clause splitter (:mod:`pipette_cli.language.clauses`) at the vocabulary's chain words
("then", "after that", ...), at ";" and at sentence ends, and at "," and "and" when what follows
asks for a command of its own (a verb such as "augment"); anything else after them stays in the
clause ("..., 64 px images", "pick and place").

A clause's command is the one whose cues (vocabulary ``intents``) weigh most: phrases 3,
verbs 2, nouns 1, and the agent's answers 1 more when the clause is a question. On a tie the
command listed first in the vocabulary wins. After a chain word, a clause with no command of its
own that names a task or an asset takes the verb of the clause before ("show me X, then the
ReadPlate protocol"); a clause that reports what happened ("the collect writing x.h5 was killed
overnight; ...") plans nothing and is read with the clause after it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pipette_cli.agent.catalog import CommandCatalog
from pipette_cli.agent.vocabulary import ANSWER_PREFIX, WEIGHTS, WorkflowVocabularySpec
from pipette_cli.language import clauses as language
from pipette_cli.language.assets import load_vocabulary as load_asset_words
from pipette_cli.language.clauses import Piece, Separators, join_words
from pipette_cli.language.lexicon import short_name
from pipette_cli.language.mentions import find_mentions
from pipette_cli.language.phrases import find_phrase, phrase_pattern, words_of

RECIPE_PREFIX = "recipe: "
"""A clause's command for a whole workflow (vocabulary ``recipes``): ``recipe: compare augmentation``."""


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

    def __init__(self, vocab: WorkflowVocabularySpec, catalog: CommandCatalog, task_names: list[str]) -> None:
        self.vocab = vocab
        self.names = task_names
        ids = {short_name(t).lower() for t in task_names} | set(load_asset_words().assets)
        self.ids = sorted(name for name in ids if len(name) > 5)
        """Task names and asset ids a verbless clause may name (:meth:`names_one`)."""
        commands = set(catalog.commands)
        filler = set(vocab.filler)
        self.option_names = {  # an option's name and its multi-word names ("render profile"), as phrases
            name: sorted(
                {
                    n
                    for p in info.params.values()
                    for n in (p.name.replace("_", " "), *(n for n in p.names if " " in n))
                    if set(n.split()) - filler
                }
            )
            for name, info in catalog.commands.items()
        }
        self.path_names = {  # every name of a path option ("table" of experts check's --markdown)
            name: sorted({n for p in info.params.values() if p.kind == "path" for n in p.names})
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

    def names_option(self, text: str, command: str, previous: str) -> bool:
        """Whether the words of ``text`` asking for ``command`` belong to the name of an option of
        ``previous`` said there ("..., with the full render profile": ``--render-profile`` of the
        collect before, not a ``sim render``; "render it again" names no option)."""
        words = words_of(find_mentions(text, self.names).words)
        cue = self.cue_words(text, command)
        verb = self.verb(text, command)
        asks = {verb} & cue if verb else set()  # "render": the word that asks for it
        # a name of several words said whole ("yield report", "render profile") shares any word of the
        # cue; a one-word name ("episodes" of "move the pending episodes") only the word that asks
        said = [
            m.group(0).split()
            for name in self.option_names.get(previous, [])
            if (m := phrase_pattern(name).search(words))
        ]
        if any(set(name) & (cue if len(name) > 1 else asks) for name in said):
            return True
        # "..., and also write the table to x.md": the cue's object names a path option of the step
        # before and the clause gives its path (not "move the pending episodes", which gives none)
        named = {w for n in self.path_names.get(previous, []) if phrase_pattern(n).search(words) for w in n.split()}
        return bool(named & cue) and bool(find_mentions(text, self.names).paths)

    def verb(self, text: str, command: str) -> str | None:
        """The first word of the verb or phrase cue of ``command`` in ``text`` ("show" in "show me
        the microplate reader asset")."""
        words = words_of(find_mentions(text, self.names).words)
        for c, weight, phrase in self.cues:
            m = phrase_pattern(phrase).search(words) if c == command and weight > WEIGHTS["nouns"] else None
            if m:
                return m.group(0).split()[0]
        return None

    def names_one(self, text: str) -> bool:
        """Whether ``text`` names a registered task or an asset by its id or name ("the ReadPlate
        protocol", "beaker_50ml"): a clause without a verb that does is another step of the verb
        before; one that does not ("then save it to x.png") completes the step before."""
        squashed = re.sub(r"[^a-z0-9_]+", "", text.lower())
        return any(name in squashed for name in self.ids)

    def again(self, text: str, command: str) -> bool:
        """Whether ``text`` asks for ``command`` once more, for a task or an asset of its own: its
        verb leads and it names one ("collect 10 demos of X, collect 10 of Y"; "export a.h5 and
        b.h5 to lerobot" stays one step)."""
        words = words_of(find_mentions(text, self.names).words).split()
        lead = next((w for w in words if w not in ("and", "also", "please", "then")), None)
        return lead is not None and lead == self.verb(text, command) and self.names_one(text)

    def happened(self, text: str) -> bool:
        """Whether ``text`` reports what happened ("the collect writing x.h5 was killed") and asks nothing."""
        return not text.rstrip().endswith("?") and find_phrase(self.vocab.happened, words_of(text)) is not None

    def about(self, text: str) -> bool:
        """Whether ``text`` only says what the request is about: it opens with a topic word and asks
        for no command ("for the demos in x.h5"), or names a file with no count ("take the demos in
        x.h5": those, not "take 20 demos")."""
        if not any(phrase_pattern(p).match(words_of(text)) for p in self.vocab.topics):
            return False
        mentions = find_mentions(text, self.names)
        counted = re.search(r"\d", mentions.words) or set(words_of(mentions.words).split()) & set(self.vocab.spelled)
        return self.best(text)[1] < WEIGHTS["verbs"] or (bool(mentions.paths) and not counted)

    def resumes(self, text: str) -> bool:
        """Whether ``text`` asks for a step again ("resume it", "continue where it stopped")."""
        return find_phrase(self.vocab.resumes, words_of(text)) is not None

    def best(self, text: str) -> tuple[str | None, int]:
        scores = self.scores(text)
        if not scores:
            return None, 0
        top = max(scores.values())
        return next(c for c in self.order if scores.get(c) == top), top


def split_clauses(text: str, intents: Intents) -> list[Clause]:
    """The clauses of ``text`` (:func:`pipette_cli.language.clauses.split_clauses`), each with
    its command (None if it names none).

    After a chain word any command starts a step; after a sentence end only a verb; after "," or
    "and" only a verb of another command ("export a.h5 and b.h5 to lerobot" is one step) or the
    same verb leading a task of its own ("collect X, collect Y"), and not when it names an
    option of the command before ("augment ... and write the yield report to x").
    A clause keeps the command of the piece that started it."""
    commands: list[str | None] = []

    def starts(piece: Piece, before: language.Clause) -> bool:
        if not commands:
            commands.append(intents.best(before.text)[0])
        command, score = intents.best(piece.text)
        previous = commands[-1]
        if intents.happened(before.text) and not intents.happened(piece.text) and intents.resumes(piece.text):
            commands.append(command)  # "the eval ... was stopped after 30 episodes; resume it": a step of its own
            return True
        if piece.after == "weak" and len(before.pieces) == 1 and intents.about(before.text):
            # "for the demos in x.h5, make ...": the command is what follows the topic
            commands[-1] = command or intents.best(join_words([*before.pieces, piece]))[0]
            return False
        if command is None and previous and piece.after == "strong" and intents.names_one(piece.text):
            verb = intents.verb(before.text, previous)  # "show me X, then the ReadPlate protocol": said once
            command, score = intents.best(f"{verb} {piece.text}") if verb else (None, 0)
        new = (
            command is not None
            and previous is not None
            and (
                piece.after == "strong"
                or (
                    score >= WEIGHTS["verbs"]
                    and (piece.after == "sentence" or command != previous or intents.again(piece.text, command))
                    and not intents.names_option(piece.text, command, previous)
                )
            )
        )
        if new:
            commands.append(command)
        else:
            commands[-1] = previous or intents.best(join_words([*before.pieces, piece]))[0] or command
        return new

    separators = Separators(strong=tuple(intents.vocab.chain.strong))
    found = language.split_clauses(text, separators, starts)
    clauses: list[Clause] = []
    told = ""  # what earlier clauses reported as having happened
    for i, (clause, command) in enumerate(zip(found, commands or [None], strict=False)):
        if i + 1 < len(found) and intents.happened(clause.text):
            # "the collect writing x.h5 was killed overnight; pack it": only the pack, told the file and task
            # (not the report's numbers: "stopped after 30 episodes" is no count for what follows)
            told += re.sub(r"(?<![\w/.-])\d[\d,.]*(?![\w/.-])", " ", clause.text) + "; "
            continue
        text = told + clause.text
        best, score = intents.best(clause.text) if command or not told else intents.best(text)  # "...; resume it"
        if best is not None and best.startswith(RECIPE_PREFIX):
            command = best  # "train X with and without augmentation": the workflow, not its first command
        elif best is not None and command is not None and score > intents.scores(text).get(command, 0) + 1:
            # the clause as a whole asks for another command far more clearly than the piece that began it
            # ("export episode 2 and 5 of x.h5 as mp4": a video, not the export verb's convert)
            command = best
        after = "strong" if clause.after == "start" or (told and not clauses) else clause.after
        clauses.append(Clause(text, command or best, score, after))
        told = ""
    return clauses
