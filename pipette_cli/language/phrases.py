"""Words and phrases, for both front-ends: a request's words with contractions spelled out, the
phrase syntax every vocabulary file uses, and phrase matching over text and over tokens.

Phrase syntax: tokens separated by spaces; ``(a|b c)`` is one of several alternatives (longest
tried first), ``word*`` any ending of ``word``, ``token?`` an optional token (never the first),
``...`` a gap of up to ten words. A phrase matches whole words only.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cache

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


def plain(text: str) -> str:
    """Lower case with typographic quotes made plain."""
    return text.lower().replace("’", "'").replace("‘", "'").replace("“", '"').replace("”", '"')


def words_of(text: str) -> str:
    """Lowercased words for cue matching: contractions spelled out ("what's" -> "what is"),
    thousands without their commas, "X-free" written "without-X" (no word for X matches it),
    punctuation other than ``' - . + %`` turned into spaces."""
    lowered = re.sub(r"(\d),(\d{3})\b", r"\1\2", plain(text))  # 1,500 -> 1500
    for pattern, spelled in _CONTRACTIONS:
        lowered = pattern.sub(spelled, lowered)
    lowered = re.sub(r"\b([a-z][\w']*)-free\b", r"without-\1", lowered)  # "teleop-free": never teleop* itself
    return " ".join(re.sub(r"[^\w'.+%π-]+", " ", lowered).split()).replace(" .", " ").rstrip(".")


def _item(token: str) -> str:
    if token.startswith("(") and token.endswith(")"):
        alternatives = sorted(token[1:-1].split("|"), key=len, reverse=True)  # "camera poses" before "camera"
        return "(?:" + "|".join(phrase_regex(alt) for alt in alternatives) + ")"
    if token.endswith("*"):
        return re.escape(token[:-1]) + r"[\w'-]*"
    return re.escape(token)


def phrase_tokens(phrase: str) -> list[str]:
    """A phrase's tokens: ``(a|b c)`` alternatives (with their ``?``) whole, other tokens by spaces."""
    return re.findall(r"\([^)]*\)\??|\S+", phrase.strip())


def phrase_regex(phrase: str) -> str:
    """The regular expression of a phrase, unbounded (see the module docstring)."""
    out, gap, lead = "", r"\s+", ""
    for token in phrase_tokens(phrase):
        if token == "...":
            gap = r"\s+(?:\S+\s+){0,10}?"
            continue
        optional = token.endswith("?") and len(token) > 1
        piece = _item(token[:-1] if optional else token)
        if not out and optional:  # "(only|just)? the top view": optional words before the first
            lead += f"(?:{piece}\\s+)?"
        elif not out:
            out = lead + piece
        elif optional:
            out += f"(?:{gap}{piece})?"
        else:
            out += gap + piece
        gap = r"\s+"
    return out


@cache
def phrase_pattern(phrase: str) -> re.Pattern[str]:
    """The regular expression of a vocabulary phrase, bounded by non-word characters."""
    return re.compile(rf"(?<![\w-]){phrase_regex(phrase)}(?![\w-])")


@cache
def any_phrase(phrases: tuple[str, ...]) -> re.Pattern[str]:
    """One pattern for several phrases, the longest first where they start alike."""
    ordered = sorted(set(phrases), key=lambda p: (-len(p), p))
    return re.compile(rf"(?<![\w'-])(?:{'|'.join(phrase_regex(p) for p in ordered)})(?![\w'-])")


def find_phrase(phrases: Iterable[str], text: str) -> re.Match[str] | None:
    """The first match of any of ``phrases`` in ``text`` (earliest position, then longest)."""
    found = [m for m in (phrase_pattern(p).search(text) for p in phrases) if m]
    return min(found, key=lambda m: (m.start(), -len(m.group(0)))) if found else None


def singular(word: str, irregular: dict[str, str] | None = None, keep: Iterable[str] = ()) -> str:
    """``tubes`` -> ``tube``, ``boxes`` -> ``box``, ``pipettes`` -> ``pipette``; ``irregular``
    forms are looked up, words in ``keep`` stay as they are."""
    if irregular and word in irregular:
        return irregular[word]
    if len(word) <= 3 or word in keep or not word.endswith("s") or word.endswith("ss"):
        return word
    if word.endswith("ies"):
        return word[:-3] + "y"
    if word.endswith(("ches", "shes", "xes", "sses")):
        return word[:-2]
    return word[:-1]


@dataclass
class Token:
    """One word (``lemma``: its singular form), a size tag, or punctuation."""

    text: str
    kind: str = "word"  # word | size | punct
    lemma: str = ""
    used: bool = False

    def __post_init__(self) -> None:
        self.lemma = self.lemma or self.text


def match(tokens: list[Token], i: int, phrase: str) -> int:
    """Tokens consumed by ``phrase`` (plain words) at position ``i`` (0 when it does not match there)."""
    parts = phrase.split()
    if i + len(parts) > len(tokens):
        return 0
    for k, word in enumerate(parts):
        token = tokens[i + k]
        if token.kind != "word" or word not in (token.text, token.lemma):
            return 0
    return len(parts)


def first_match(tokens: list[Token], i: int, phrases: Iterable[str]) -> tuple[str, int] | None:
    """The longest of ``phrases`` matching at ``i``."""
    best: tuple[str, int] | None = None
    for phrase in phrases:
        n = match(tokens, i, phrase)
        if n and (best is None or n > best[1]):
            best = (phrase, n)
    return best
