"""Sentence-level text handling of the offline parser: normalising, polite forms, numbers the
description states (thresholds), robot names, tokens with sizes and singular forms, and the split
into steps ("..., then ...", "first ... and then ...", "after that").

Every word list comes from the vocabulary (``assets/vocabulary.yaml``); nothing here knows a
phrasing.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Container

from pipette_cli.language.assets import Vocabulary, VocabularySpec
from pipette_cli.language.clauses import Piece, Separators, split_clauses
from pipette_cli.language.phrases import Token, any_phrase, singular

SIZE_PATTERNS: tuple[tuple[str, Callable[[re.Match[str]], list[str]]], ...] = (
    (r"(\d+(?:\.\d+)?)\s*(?:x|by)\s*(\d+)\s*(?:mm)?\b", lambda m: [f"{m[1]}x{m[2]}", f"{m[1]}mm"]),
    (r"(\d+(?:\.\d+)?)\s*(?:ml|millilit(?:er|re)s?|cc)\b", lambda m: [f"{float(m[1]):g}ml"]),
    (r"(\d+(?:\.\d+)?)\s*(?:l|lit(?:er|re)s?)\b", lambda m: [f"{float(m[1]) * 1000:g}ml"]),
    (r"(\d+(?:\.\d+)?)\s*(?:ul|microlit(?:er|re)s?)\b", lambda m: [f"{float(m[1]):g}ul"]),
    (r"(\d+(?:\.\d+)?)\s*(?:mm|millimet(?:er|re)s?)\b", lambda m: [f"{float(m[1]):g}mm"]),
    (r"(\d+(?:\.\d+)?)\s*(?:cm|centimet(?:er|re)s?)\b", lambda m: [f"{float(m[1]) * 10:g}mm"]),
    (r"(\d+)\s*wells?\b", lambda m: [f"{m[1]}well"]),
    (r"(\d+)(?=\s*deep\s*wells?\b)", lambda m: [f"{m[1]}well"]),  # "96 deep-well plate": a 96-well deep well plate
    (r"(\d+)\s*channels?\b", lambda m: [f"{m[1]}channel"]),
    (r"\bp\s?(\d+)\b", lambda m: [f"p{m[1]}"]),
    (r"\bt\s?(25|75|150|175|225)\b", lambda m: [f"t{m[1]}"]),
)
SECONDS = r"(?:seconds?|secs?|s)\b"
THRESHOLD_PATTERNS: tuple[tuple[str, str, float], ...] = (
    # (regex, field, scale); the first group (or the one named n) is the number; the match (or the
    # group named said) is taken out of the text
    (
        r"\b(?:by|at least|to a height of|a height of|lift(?:ed)? it|raise(?:d)? it|up)\s+(?:about\s+|around\s+|roughly\s+)?(\d+(?:\.\d+)?)\s*cm\b",
        "lift_height_m",
        0.01,
    ),
    (r"\b(?:by|at least|to a height of|a height of|up)\s+(\d+(?:\.\d+)?)\s*mm\b", "lift_height_m", 0.001),
    (  # "lift the tube about 5 cm": only the height is taken out of the text, not the verb and object
        r"\b(?:lift|raise)\w*\b[^.,;]*?\s(?P<said>(?:about\s+|around\s+|roughly\s+)?(?P<n>\d+(?:\.\d+)?)\s*cm)\b",
        "lift_height_m",
        0.01,
    ),
    (rf"\bfor\s+(?:at least\s+|about\s+|around\s+)?(\d+(?:\.\d+)?)\s*{SECONDS}", "hold_s", 1.0),
    (rf"\b(?:within|in under|in less than|under|in)\s+(\d+(?:\.\d+)?)\s*{SECONDS}", "timeout_s", 1.0),
    (r"\b(?:within|in under|in less than|under|in)\s+(\d+(?:\.\d+)?)\s*(?:min|mins|minutes?)\b", "timeout_s", 60.0),
    (
        r"\btilt(?:ing|ed)?\s+(?:it\s+)?(?:more than|over|by more than|beyond|past)\s+(\d+(?:\.\d+)?)\s*(?:deg|degrees?)\b",
        "max_tilt_deg",
        1.0,
    ),
    (r"\bwithin\s+(\d+(?:\.\d+)?)\s*cm\s+of\b", "xy_tolerance_m", 0.01),
    (r"\bwithin\s+(\d+(?:\.\d+)?)\s*mm\s+of\b", "xy_tolerance_m", 0.001),
)
UPRIGHT = r"\b(upright|without tilting|not tilt|keep(?:ing)? it level|level|without spilling)\b"
NEGATION = r"\b(don't|dont|do not|never|must not|mustn't|should not|shouldn't|avoid)\b"


def normalise(description: str, words: VocabularySpec) -> str:
    """Lower case, plain ASCII units, numbers without thousands commas, hyphens split, numbers
    written as words before units, polite forms and negation-free spacing."""
    s = description.lower().replace("µ", "u").replace("μ", "u").replace("×", "x").replace("’", "'").replace("°", " deg")
    s = s.replace("“", '"').replace("”", '"')
    s = re.sub(r"(\d),(\d{3})\b", r"\1\2", s)  # 1,000 -> 1000
    s = re.sub(
        r"without (?:its |a |the )?caps?\b|\b(?:with )?no caps?\b|\bcap(?:ped)? off\b|\bwith the cap removed\b",
        " nocap ",
        s,
    )
    s = re.sub(r"(?<=[a-z])-(?=[a-z])", " ", s)  # multi-channel -> multi channel
    s = re.sub(r"(?<=\d)-(?=[a-z])|(?<=[a-z])-(?=\d)", " ", s)  # 96-well, t-75
    s = re.sub(r"'s\b", " ", s)
    units = r"(?=\s*(?:s|secs?|seconds?|min|mins|minutes?|cm|mm|ml|ul|l|deg|degrees?|wells?|channels?)\b)"
    for word, value in sorted(words.numbers.items(), key=lambda kv: -len(kv[0])):
        s = re.sub(rf"\b{re.escape(word)}\b{units}", f"{value:g}", s)
    s = any_phrase(tuple(words.polite)).sub(" ", s)
    return re.sub(r"\s+", " ", s).strip()


def inverted_of(text: str, names: Container[str]) -> str:
    """ "a roll of yellow tape" -> "a yellow tape roll" where "tape roll" is a name ("N1 of [words]
    N2" names an N2 N1: a box of tips, a rack of tubes); other "of"s are left as written."""

    def turn(m: re.Match[str]) -> str:
        head, after = m[1], m[2].split()
        for k, noun in enumerate(after):
            for name in (f"{noun} {head}", f"{singular(noun)} {head}"):
                if name in names:
                    return " ".join([*after[:k], name, *after[k + 1 :]])
        return m[0]

    return re.sub(r"\b([a-z]+) of (?:the |a |an |some )?((?:[a-z]+ ){0,2}[a-z]+)\b", turn, text)


def has_negation(text: str) -> bool:
    return re.search(NEGATION, text) is not None


def extract_thresholds(text: str) -> tuple[str, dict[str, float]]:
    """Numbers the description states (``lift it by 5 cm``, ``for 2 seconds``...), and the text without them."""
    found: dict[str, float] = {}
    for pattern, name, scale in THRESHOLD_PATTERNS:
        for m in re.finditer(pattern, text):
            named = m.re.groupindex  # a pattern may say which group is the number (n) and which words go (said)
            if name not in found:
                found[name] = round(float(m.group("n" if "n" in named else 1)) * scale, 6)
            start = m.start("said") if "said" in named else m.start()
            text = text[:start] + " " * (m.end() - start) + text[m.end() :]
    if re.search(UPRIGHT, text) and "max_tilt_deg" not in found:
        found["max_tilt_deg"] = 15.0
    return text, found


def tokenise(text: str, vocab: Vocabulary) -> list[Token]:
    """Words (with singular lemmas), size tags and punctuation."""
    spans: list[tuple[int, int, list[str]]] = []
    for pattern, make in SIZE_PATTERNS:
        for m in re.finditer(pattern, text):
            if any(s < m.end() and m.start() < e for s, e, _ in spans):
                continue
            spans.append((m.start(), m.end(), make(m)))
    spans.sort()
    tokens: list[Token] = []
    pos = 0
    known = set(vocab.alias_to_kind) | {w for ws in vocab.words.actions.values() for p in ws for w in p.split()}
    for start, end, tags in [*spans, (len(text), len(text), [])]:
        for word in re.findall(r"[a-z0-9][a-z0-9']*|[,.;:!?]", text[pos:start]):
            if word in ",.;:!?":
                tokens.append(Token(word, "punct"))
            else:
                lemma = (
                    word
                    if word in known
                    else singular(word, vocab.words.plurals.irregular, vocab.words.plurals.singular)
                )
                tokens.append(Token(word, "word", lemma))
        tokens.extend(Token(tag, "size") for tag in tags)
        pos = end
    return tokens


def split_steps(text: str, reader_is_verb: Callable[[list[Token], int], bool], vocab: Vocabulary) -> list[list[Token]]:
    """A normalised description -> the tokens of each step (:func:`pipette_cli.language.clauses.split_clauses`):
    at sentence punctuation, at sequence words ("then", "after that"), and at "and", "," or ":"
    followed by a new verb ("pick up the tube and put it ..."). Words that only mark the first
    step ("first") are dropped; "next to" is a place, not "next"."""
    words = vocab.words
    skip = set(words.fillers) - set(words.articles)
    separators = Separators(
        strong=tuple(words.sequence),
        weak=(",", ":", "and", "&"),
        openers=tuple(words.first),
        keep=tuple(p for p, _ in words.preposition_roles() if len(p.split()) > 1),
    )

    def starts(piece: Piece, _before: object) -> bool:
        if piece.after != "weak":
            return True
        tokens = tokenise(piece.text, vocab)
        k = 0
        while k < len(tokens) and tokens[k].kind == "word" and tokens[k].text in skip and not reader_is_verb(tokens, k):
            k += 1
        return k < len(tokens) and reader_is_verb(tokens, k)

    steps = [tokenise(clause.text, vocab) for clause in split_clauses(text, separators, starts)]
    return [s for s in steps if any(t.kind == "word" for t in s)]


SUBORDINATORS = {"after": True, "before": False}
"""A word that opens a step inside another ("..., after closing its lid"): True when that step is
done first."""
SUBJECTS = ("you", "we", "i", "they")
"""Who does a subordinate step ("... after you open the lid"): the robot; the word is dropped."""
CONDITIONS = ("once", "when", "until", "while", "after", "before")
"""Words that open a condition rather than a step ("... once the spin finishes"): a task has no
such conditions, so their words are listed as not understood, never read as objects."""


def subordinates(
    steps: list[list[Token]], is_verb: Callable[[list[Token], int], bool]
) -> tuple[list[list[Token]], dict[int, int], list[str]]:
    """Steps with "after/before + verb" split off their main step ("start the thermal cycler after
    closing its lid" -> "start the thermal cycler", "closing its lid"), in the order they are read
    (a pronoun in the subordinate step refers to the main step's object); for each subordinate
    step done first, the index of the main step it goes before; and the words of conditions cut
    off their step ("remove the tube once the spin finishes": 'once', 'spin', 'finishes')."""
    out: list[list[Token]] = []
    first: dict[int, int] = {}
    conditions: list[str] = []
    for tokens in steps:
        k = next(
            (k for k in range(1, len(tokens) - 1) if tokens[k].kind == "word" and tokens[k].text in CONDITIONS),
            None,
        )
        j = k + 1 if k is not None and k + 1 < len(tokens) - 1 and tokens[k + 1].text in SUBJECTS else k
        if k is None or j is None:
            out.append(tokens)
        elif tokens[k].text in SUBORDINATORS and is_verb(tokens, j + 1):
            out += [tokens[:k], tokens[j + 1 :]]
            if SUBORDINATORS[tokens[k].text]:
                first[len(out) - 1] = len(out) - 2
        else:
            out.append(tokens[:k])
            conditions += [t.text for t in tokens[k:] if t.kind != "punct"]
    return out, first, conditions
