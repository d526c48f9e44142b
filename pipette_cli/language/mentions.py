"""What a request or description names, found before any word is read: paths and addresses,
and names from a lexicon (assets, robots, suites) matched whole before their parts.

A path is a token with a ``/``, a file name with a known suffix (``x.h5``), or a name that exists
on disk and does not read as a plain word (it has a dot, underscore, dash or digit, so ``data``
stays a word where a ``data/`` folder exists). An address is ``tcp://host:port``, ``host:port``
or "port N" (on this machine). Both are blanked out of the words the parsers read, so
``outputs/train/act/...`` neither asks for ``pipette train`` nor names the ACT policy.

A name is the longest lexicon phrase at a position; where names overlap, a compound's head is its
last name ("pipette tip box" is one tip box, not a pipette tip and an unknown "box").
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, replace
from pathlib import Path

from pipette_cli.language.phrases import Token, first_match, plain

FILEFILE_SUFFIXES = (
    "h5",
    "hdf5",
    "png",
    "jpg",
    "gif",
    "mp4",
    "yaml",
    "yml",
    "json",
    "csv",
    "md",
    "usd",
    "usda",
    "usdc",
    "safetensors",
    "pt",
    "log",
)
FILE_SUFFIX = re.compile(rf"\.(?:{'|'.join(FILEFILE_SUFFIXES)})$", re.IGNORECASE)
_URL = re.compile(r"^[a-z][a-z0-9+.-]*://\S+$", re.IGNORECASE)
_HOST_PORT = re.compile(r"^(?:localhost|[a-z0-9-]*[a-z][a-z0-9.-]*|\d{1,3}(?:\.\d{1,3}){3}):\d{2,5}$", re.IGNORECASE)
_PORT = re.compile(r"\bport\s*(?:number\s*)?[:=]?\s*(\d{2,5})\b", re.IGNORECASE)
ARROW = re.compile(r"->|=>|→|⇒")
"""An arrow before a path ("a.h5 -> b.h5") says where the first goes: read as "to"."""
_STRIP_LEFT, _STRIP_RIGHT = "([{\"'“‘<", ")]}\"'”’.,;:!?>"
LOCAL_HOST = "127.0.0.1"


@dataclass(frozen=True)
class PathMention:
    path: str
    before: str
    """Up to four lowercased words just before the path ("the policy in")."""
    listed: bool = False
    """It continues a list of paths ("a.h5 b.h5", "a.h5, b.h5", "a.h5 and b.h5")."""


@dataclass(frozen=True)
class Mentions:
    words: str
    """The request with paths and addresses taken out: what the parser reads as words."""
    paths: list[PathMention]
    addresses: list[tuple[str, str]]
    """(``tcp://host:port``, as written)."""


def _is_path(token: str) -> bool:
    if not re.search(r"[A-Za-z]", token) or not re.fullmatch(r"[\w.~/+-]+", token):
        return False
    if "/" in token or FILE_SUFFIX.search(token):
        return True
    return bool(re.search(r"[._\-~\d]", token)) and Path(token).expanduser().exists()


def find_mentions(text: str, names: Iterable[str] = ()) -> Mentions:
    """Split ``text`` into its words, its paths and its addresses; ``names`` (task ids such as
    ``pipette/PickUpTestTube-v1``, alone or comma-separated) stay words although they hold a ``/``."""
    known = {n.lower() for n in names}
    text = ARROW.sub(r" \g<0> ", text)  # "a.h5->b.h5": two paths
    kept: list[str] = []
    paths: list[PathMention] = []
    addresses: list[tuple[str, str]] = []
    since: list[str] | None = None  # words since the last path
    for token in text.split():
        core = token.strip(_STRIP_LEFT).rstrip(_STRIP_RIGHT)
        if core and _URL.match(core):
            addresses.append((core, core))
        elif core and _HOST_PORT.match(core):
            addresses.append((f"tcp://{core}", core))
        elif core and _is_path(core) and not all(part in known for part in core.lower().split(",")):
            said = " ".join("to" if ARROW.fullmatch(w) else w for w in kept)
            before = " ".join(re.findall(r"[a-z0-9π-]+", said.lower())[-4:])
            listed = since is not None and all(w.strip(",") in ("", "and", "&") for w in since)
            paths.append(PathMention(core, before, listed))
            since = []
        else:
            kept.append(token)
            if since is not None:
                since.append(token.lower())
    words = " ".join(kept)
    for m in _PORT.finditer(words):
        addresses.append((f"tcp://{LOCAL_HOST}:{m.group(1)}", m.group(0)))
    return Mentions(_PORT.sub(" ", words), paths, addresses)


@dataclass(frozen=True)
class Name:
    """A lexicon phrase found in a text: tokens ``start:end``, the head phrase it resolves to."""

    start: int
    end: int
    phrase: str
    compound: bool = False
    """Several names overlap here; ``phrase`` is the last one's."""
    span: tuple[int, int] = (0, 0)
    """Characters of the text it stands at (:func:`names_in`)."""


def name_at(tokens: list[Token], i: int, phrases: list[str], stop: AbstractSet[int] = frozenset()) -> Name | None:
    """The name starting at token ``i``: the longest of ``phrases`` there; where a later name
    overlaps it and ends after it ("pipette tip" + "tip box"), the compound up to the last name's
    end, resolved to that last name. Tokens in ``stop`` end a compound."""
    found = first_match(tokens, i, phrases)
    if found is None:
        return None
    head, end, compound = found[0], i + found[1], False
    j = i + 1
    while j < end and j not in stop:
        later = first_match(tokens, j, phrases)
        if later is not None and j + later[1] > end:
            head, end, compound = later[0], j + later[1], True
        j += 1
    return Name(i, end, head, compound)


_WORD = re.compile(r"[a-z0-9][a-z0-9'.]*[a-z0-9]|[a-z0-9]")


def word_tokens(text: str, singular: Callable[[str], str] = lambda w: w) -> list[Token]:
    """The words of ``text`` as tokens (lower case, ``singular`` lemmas)."""
    return [Token(w, "word", singular(w)) for w in _WORD.findall(plain(text))]


def names_in(text: str, phrases: list[str], singular: Callable[[str], str] = lambda w: w) -> list[Name]:
    """Every name of ``phrases`` in ``text``, left to right, none overlapping (see :func:`name_at`);
    ``span`` is where each stands in ``plain(text)``."""
    found = list(_WORD.finditer(plain(text)))
    tokens = [Token(m.group(0), "word", singular(m.group(0))) for m in found]
    out: list[Name] = []
    i = 0
    while i < len(tokens):
        name = name_at(tokens, i, phrases)
        if name is None:
            i += 1
            continue
        out.append(replace(name, span=(found[name.start].start(), found[name.end - 1].end())))
        i = name.end
    return out
