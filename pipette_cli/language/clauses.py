"""The one clause splitter: a request or a task description -> its clauses.

Text is cut at sentence ends (``;`` ``!`` ``?``, a full stop before a word), at *strong*
separators (sequence words from a vocabulary: "then", "after that", "followed by") and at *weak*
ones ("," and "and"). Words that only open a clause ("first", "to begin with") are dropped, and
phrases that merely start like a sequence word ("next to") are kept whole.

Which cut starts a new clause is the grammar's decision (``starts``): the workflow grammar starts
one where a piece asks for a command of its own, the task grammar where a verb follows. A piece
that does not start a clause is joined to the clause before, with its separator.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache

from pipette_cli.language.phrases import phrase_regex

_SENTENCE = r"[;!?]\s*(?=\S)|\.\s+(?=[A-Za-z])"
_LIST_MARK = r"(?:^|(?<=\s))\(?\d{1,2}\)\s+"
"""A numbered list's marker ("1) collect ... 2) replay ..."): a strong separator."""
LIST_MARK = re.compile(_LIST_MARK)


@dataclass(frozen=True)
class Separators:
    """The words that separate clauses, from a vocabulary."""

    strong: tuple[str, ...]
    """Phrases that always end a clause ("then", "after that"); phrase syntax."""
    weak: tuple[str, ...] = (",", "and")
    """Separators that end one only where the grammar says so."""
    openers: tuple[str, ...] = ()
    """Phrases that only open a clause ("first"), dropped there."""
    keep: tuple[str, ...] = ()
    """Phrases that start like a strong one but are not ("next to")."""


@dataclass(frozen=True)
class Piece:
    """Text between two separators."""

    text: str
    after: str
    """What separates it from the piece before: ``start``, ``strong``, ``sentence`` or ``weak``."""
    separator: str = ""


@dataclass
class Clause:
    """One clause: the pieces it joins."""

    pieces: list[Piece] = field(default_factory=list)

    @property
    def text(self) -> str:
        first, *rest = self.pieces
        return (first.text + "".join(p.separator + p.text for p in rest)).strip(" ,;:")

    @property
    def after(self) -> str:
        return self.pieces[0].after


RANK = {"weak": 0, "sentence": 1, "strong": 2}


def _weak(word: str) -> str:
    if word == ",":
        return r",\s+"
    return rf"\s+{re.escape(word)}\s+" if word[0].isalpha() else rf"\s*{re.escape(word)}\s+"


@cache
def _pattern(separators: Separators) -> re.Pattern[str]:
    strong = []
    for phrase in sorted(separators.strong, key=len, reverse=True):
        # "next" separates, "next to" does not
        tails = [k[len(phrase) :].strip() for k in separators.keep if k.startswith(phrase + " ")]
        guard = f"(?!\\s+(?:{'|'.join(re.escape(t) for t in tails)})\\b)" if tails else ""
        strong.append(phrase_regex(phrase) + guard)
    weak = "|".join(_weak(w) for w in separators.weak)
    return re.compile(
        rf"(?P<strong>(?:,\s*|\s+and\s+|\s+|(?<=\s)|^)(?<![\w-])(?:{'|'.join(strong)})(?![\w-])[\s,:]*|{_LIST_MARK})"
        rf"|(?P<sentence>{_SENTENCE})|(?P<weak>{weak})",
        re.IGNORECASE,
    )


def pieces(text: str, separators: Separators) -> list[Piece]:
    """``text`` cut at every separator; empty pieces dropped (the stronger of the separators
    around one stays), openers taken off each piece's start."""
    opener = (
        re.compile(rf"^\s*(?:{'|'.join(phrase_regex(p) for p in separators.openers)})(?![\w-])[\s,:]*", re.IGNORECASE)
        if separators.openers
        else None
    )
    out: list[Piece] = []
    kind: str | None = None  # the strongest separator since the last piece
    separator, position = "", 0
    for m in [*_pattern(separators).finditer(text), None]:
        piece = text[position : m.start() if m else len(text)]
        if opener is not None:
            piece = opener.sub("", piece)
        if piece.strip(" ,;:"):
            out.append(Piece(piece, kind or "weak", separator) if out else Piece(piece, "start"))
            kind, separator = None, ""
        if m is not None:
            found = m.lastgroup or "weak"
            kind = found if kind is None or RANK[found] > RANK[kind] else kind
            separator, position = separator + m.group(0), m.end()
    return out


def split_clauses(
    text: str, separators: Separators, starts: Callable[[Piece, Clause], bool] | None = None
) -> list[Clause]:
    """The clauses of ``text``: each piece starts one where ``starts(piece, clause before)`` says
    so (by default after a strong separator or a sentence end), or joins the clause before."""
    starts = starts or (lambda piece, _before: piece.after in ("strong", "sentence"))
    clauses: list[Clause] = []
    for piece in pieces(text, separators):
        if not clauses or starts(piece, clauses[-1]):
            clauses.append(Clause([piece]))
        else:
            clauses[-1].pieces.append(piece)
    return clauses


def join_words(pieces: Sequence[Piece]) -> str:
    """Pieces written back as one text, with their separators."""
    return "".join((p.separator if i else "") + p.text for i, p in enumerate(pieces))
