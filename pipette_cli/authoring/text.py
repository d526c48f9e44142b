"""Sentence-level text handling of the offline parser: normalising, polite forms, numbers the
description states (thresholds), robot names, tokens with sizes and singular forms, and the split
into steps ("..., then ...", "first ... and then ...", "after that").

Every word list comes from the vocabulary (``assets/vocabulary.yaml``); nothing here knows a
phrasing.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

from pipette_cli.authoring.vocabulary import Vocabulary, VocabularySpec
from pipette_cli.specs.robot import robot_words

SIZE_PATTERNS: tuple[tuple[str, Callable[[re.Match[str]], list[str]]], ...] = (
    (r"(\d+(?:\.\d+)?)\s*(?:x|by)\s*(\d+)\s*(?:mm)?\b", lambda m: [f"{m[1]}x{m[2]}", f"{m[1]}mm"]),
    (r"(\d+(?:\.\d+)?)\s*(?:ml|millilit(?:er|re)s?|cc)\b", lambda m: [f"{float(m[1]):g}ml"]),
    (r"(\d+(?:\.\d+)?)\s*(?:l|lit(?:er|re)s?)\b", lambda m: [f"{float(m[1]) * 1000:g}ml"]),
    (r"(\d+(?:\.\d+)?)\s*(?:ul|microlit(?:er|re)s?)\b", lambda m: [f"{float(m[1]):g}ul"]),
    (r"(\d+(?:\.\d+)?)\s*(?:mm|millimet(?:er|re)s?)\b", lambda m: [f"{float(m[1]):g}mm"]),
    (r"(\d+(?:\.\d+)?)\s*(?:cm|centimet(?:er|re)s?)\b", lambda m: [f"{float(m[1]) * 10:g}mm"]),
    (r"(\d+)\s*wells?\b", lambda m: [f"{m[1]}well"]),
    (r"(\d+)\s*channels?\b", lambda m: [f"{m[1]}channel"]),
    (r"\bp\s?(\d+)\b", lambda m: [f"p{m[1]}"]),
    (r"\bt\s?(25|75|150|175|225)\b", lambda m: [f"t{m[1]}"]),
)
SECONDS = r"(?:seconds?|secs?|s)\b"
THRESHOLD_PATTERNS: tuple[tuple[str, str, float], ...] = (
    # (regex, field, scale); the first group is the number
    (
        r"\b(?:by|at least|to a height of|a height of|lift(?:ed)? it|raise(?:d)? it|up)\s+(\d+(?:\.\d+)?)\s*cm\b",
        "lift_height_m",
        0.01,
    ),
    (r"\b(?:by|at least|to a height of|a height of|up)\s+(\d+(?:\.\d+)?)\s*mm\b", "lift_height_m", 0.001),
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


@dataclass
class Token:
    """One word (``lemma``: its singular form), a size tag, or punctuation."""

    text: str
    kind: str = "word"  # word | size | punct
    lemma: str = ""
    used: bool = False

    def __post_init__(self) -> None:
        self.lemma = self.lemma or self.text


def _alternation(phrases: list[str]) -> str:
    ordered = sorted(set(phrases), key=lambda p: (-len(p), p))
    return "|".join(re.escape(p).replace(r"\ ", r"\s+") for p in ordered)


@cache
def _polite_pattern(polite: tuple[str, ...]) -> re.Pattern[str]:
    return re.compile(rf"(?<![\w'])(?:{_alternation(list(polite))})(?![\w'])[,!]?")


def normalise(description: str, words: VocabularySpec) -> str:
    """Lower case, plain ASCII units, numbers without thousands commas, hyphens split, numbers
    written as words before units, polite forms and negation-free spacing."""
    s = description.lower().replace("µ", "u").replace("μ", "u").replace("×", "x").replace("’", "'").replace("°", " deg")
    s = s.replace("“", '"').replace("”", '"')
    s = re.sub(r"(\d),(\d{3})\b", r"\1\2", s)  # 1,000 -> 1000
    s = re.sub(
        r"without (?:its |a |the )?caps?\b|\bno caps?\b|\bcap(?:ped)? off\b|\bwith the cap removed\b", " nocap ", s
    )
    s = re.sub(r"(?<=[a-z])-(?=[a-z])", " ", s)  # multi-channel -> multi channel
    s = re.sub(r"(?<=\d)-(?=[a-z])|(?<=[a-z])-(?=\d)", " ", s)  # 96-well, t-75
    s = re.sub(r"'s\b", " ", s)
    units = r"(?=\s*(?:s|secs?|seconds?|min|mins|minutes?|cm|mm|ml|ul|l|deg|degrees?|wells?|channels?)\b)"
    for word, value in sorted(words.numbers.items(), key=lambda kv: -len(kv[0])):
        s = re.sub(rf"\b{re.escape(word)}\b{units}", f"{value:g}", s)
    s = _polite_pattern(tuple(words.polite)).sub(" ", s)
    return re.sub(r"\s+", " ", s).strip()


def has_negation(text: str) -> bool:
    return re.search(NEGATION, text) is not None


def extract_thresholds(text: str) -> tuple[str, dict[str, float]]:
    """Numbers the description states (``lift it by 5 cm``, ``for 2 seconds``...), and the text without them."""
    found: dict[str, float] = {}
    for pattern, name, scale in THRESHOLD_PATTERNS:
        for m in re.finditer(pattern, text):
            if name not in found:
                found[name] = round(float(m.group(1)) * scale, 6)
            text = text[: m.start()] + " " * (m.end() - m.start()) + text[m.end() :]
    if re.search(UPRIGHT, text) and "max_tilt_deg" not in found:
        found["max_tilt_deg"] = 15.0
    return text, found


def extract_robots(text: str) -> tuple[str, list[str]]:
    """Robots the description names (``with the Piper arm``; their names: the robot registry's,
    :func:`~pipette_cli.specs.robot.robot_words`), and the text without them."""
    robots: list[str] = []
    for robot, names in robot_words().items():
        for name in names:
            if re.search(rf"\b{re.escape(name)}\b", text):
                if robot not in robots:
                    robots.append(robot)
                text = re.sub(rf"\b(?:with|using|by)?\s*(?:the\s+)?{re.escape(name)}(?:\s+(?:arm|robot))?\b", " ", text)
    return text, robots


def singular(word: str, words: VocabularySpec) -> str:
    """``tubes`` -> ``tube``, ``boxes`` -> ``box``, ``pipettes`` -> ``pipette``; words in
    ``plurals.singular`` stay as they are."""
    if word in words.plurals.irregular:
        return words.plurals.irregular[word]
    if len(word) <= 3 or word in words.plurals.singular or not word.endswith("s") or word.endswith("ss"):
        return word
    if word.endswith("ies"):
        return word[:-3] + "y"
    if word.endswith(("ches", "shes", "xes", "sses")):
        return word[:-2]
    return word[:-1]


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
                lemma = word if word in known else singular(word, vocab.words)
                tokens.append(Token(word, "word", lemma))
        tokens.extend(Token(tag, "size") for tag in tags)
        pos = end
    return tokens


def match(tokens: list[Token], i: int, phrase: str) -> int:
    """Tokens consumed by ``phrase`` at position ``i`` (0 when it does not match there)."""
    parts = phrase.split()
    if i + len(parts) > len(tokens):
        return 0
    for k, word in enumerate(parts):
        token = tokens[i + k]
        if token.kind != "word" or word not in (token.text, token.lemma):
            return 0
    return len(parts)


def first_match(tokens: list[Token], i: int, phrases: list[str]) -> tuple[str, int] | None:
    """The longest of ``phrases`` matching at ``i``."""
    best: tuple[str, int] | None = None
    for phrase in phrases:
        n = match(tokens, i, phrase)
        if n and (best is None or n > best[1]):
            best = (phrase, n)
    return best


def split_steps(
    tokens: list[Token], vocab: Vocabulary, is_verb: Callable[[list[Token], int], bool]
) -> list[list[Token]]:
    """Split a description into steps: at sentence punctuation, at sequence words ("then",
    "after that"), and at "and" or "," followed by a new verb ("pick up the tube and put it ...").
    Words that only mark the first step ("first") are dropped."""
    words = vocab.words
    skip = set(words.fillers) - set(words.articles)
    prepositions = [p for p, _ in words.preposition_roles() if len(p.split()) > 1]
    steps: list[list[Token]] = [[]]
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if token.kind == "punct" and token.text in ".;!?":
            steps.append([])
            i += 1
            continue
        prep = first_match(tokens, i, prepositions)  # "next to" is a place, not "next"
        if prep is not None:
            steps[-1].extend(tokens[i : i + prep[1]])
            i += prep[1]
            continue
        marker = first_match(tokens, i, words.sequence)
        if marker is not None:
            steps.append([])
            i += marker[1]
            continue
        opener = first_match(tokens, i, words.first)
        if opener is not None:
            i += opener[1]
            continue
        if (token.kind == "punct" and token.text in ",:") or token.text in ("and", "&"):
            k = i + 1
            while k < len(tokens) and tokens[k].kind == "word" and tokens[k].text in skip and not is_verb(tokens, k):
                k += 1
            if k < len(tokens) and is_verb(tokens, k):
                steps.append([])
                i += 1
                continue
        steps[-1].append(token)
        i += 1
    return [s for s in steps if any(t.kind == "word" for t in s)]
