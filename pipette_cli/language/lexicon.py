"""The lexicon both front-ends read, built from the registries: every robot's names (its id,
aliases and words from ``registry/robots/``), every evaluation suite's names, and the asset
library's kinds and aliases (:mod:`.assets`). Nothing here is a phrasing: add a robot, a suite or
an asset and both ``pipette agent`` and ``pipette new-task`` know its names.
"""

from __future__ import annotations

import itertools
import re
from functools import cache
from typing import TYPE_CHECKING

from pipette_cli.errors import PipetteError
from pipette_cli.language.phrases import phrase_pattern, phrase_tokens
from pipette_cli.specs.robot import robot_words

if TYPE_CHECKING:
    from pipette_cli.registry import Registry

_SUFFIXES = ("ing", "ed", "es", "s", "e")


def stem(word: str) -> str:
    """A crude stem, the same for a word's usual forms (close, closes, closing, closed -> clos)."""
    for _ in range(2):
        for suffix in _SUFFIXES:
            if word.endswith(suffix) and len(word) - len(suffix) >= 3:
                word = word[: -len(suffix)]
                break
    return word


def stems(text: str) -> str:
    """Every word of ``text`` by its :func:`stem`."""
    return " ".join(stem(w) for w in text.split())


@cache
def stem_phrase(phrase: str) -> str:
    """A vocabulary phrase with its words stemmed as :func:`stems` stems a request's, inside ``(a|b)``
    alternatives too; ``word*`` and ``...`` stay as written (``phrases`` syntax)."""

    def one(token: str) -> str:
        optional = "?" if token.endswith("?") and len(token) > 1 else ""
        token = token[: len(token) - len(optional)]
        if token.startswith("(") and token.endswith(")"):
            return "(" + "|".join(stems(alt) for alt in token[1:-1].split("|")) + ")" + optional
        return (token if token.endswith("*") or token == "..." else stem(token)) + optional

    return " ".join(one(t) for t in phrase_tokens(phrase))


def camel_words(name: str) -> list[str]:
    """``PickUpTestTube`` -> ``["pick", "up", "test", "tube"]``."""
    return [w.lower() for w in re.findall(r"[A-Z][a-z]*|[0-9]+[a-z]*", name)]


def short_name(task_id: str) -> str:
    """``pipette/PickUpTestTube-v1`` -> ``PickUpTestTube``."""
    return task_id.split("/", 1)[-1].rsplit("-v", 1)[0]


ROBOT_AROUND = r"(?:(?:with|using|by)\s+)?(?:the\s+)?{name}(?:\s+(?:arm|robot))?"
"""How a robot's name stands in a sentence: "with the Piper arm", "using the UR5e", "by the panda robot"."""


def suite_words(registry: Registry) -> dict[str, list[str]]:
    """Suite id -> the words that name it: its id and the words of its name ("paper benchmark"),
    and any part of them followed by "suite" that names no other suite ("the nominal suite"), and all
    of its words said apart in any order ("the paper benchmark with paraphrased instructions")."""
    from pipette_cli.evaluation.suites import load_suites  # deferred: suites only when a lexicon is built

    try:
        ids = load_suites(registry).ids()
    except PipetteError:
        return {}  # a broken suite file: `pipette eval --suite` says what is wrong with it
    words = {sid: camel_words(short_name(sid)) for sid in ids}
    parts: dict[str, list[str]] = {}
    for sid, name in words.items():
        for size in range(1, min(len(name), 4) + 1):  # any of its words, in any order ("the paraphrased paper suite")
            for chosen in itertools.permutations(name, size):
                parts.setdefault(f"{' '.join(chosen)} suite", []).append(sid)

    def owner(suites: list[str]) -> str | None:  # a part several suites share names the one with the fewest words
        fewest = min(len(words[s]) for s in suites)
        basic = [s for s in suites if len(words[s]) == fewest]
        return basic[0] if len(basic) == 1 else None

    return {
        sid: sorted(
            {
                sid.lower(),
                sid.split("/")[-1].lower(),
                " ".join(name),
                *(p for p, owners in parts.items() if owner(owners) == sid),
                # all of its words, in any order and apart ("the paper benchmark with paraphrased instructions")
                *(" ... ".join(order) for order in itertools.permutations(name) if len(name) > 1),
            },
            key=len,
            reverse=True,
        )
        for sid, name in words.items()
    }


def tag_words(registry: Registry) -> dict[str, list[str]]:
    """Tag or category -> its words, singular and plural ("protocol": "the protocols")."""
    out: dict[str, list[str]] = {}
    for tid in registry.ids():
        spec = registry.get(tid)
        for tag in [*spec.tags, spec.category]:
            said = re.sub(r"[-_]+", " ", tag)
            out[tag] = sorted({tag, said, f"({said}|{said}s)"}, key=len, reverse=True)
    return out


def registry_values(registry: Registry) -> dict[str, dict[str, list[str]]]:
    """Option values the registries name: ``robot`` (robot id -> names), ``suite_id`` and ``tag``
    (its tags and categories)."""
    return {"robot": robot_words(), "suite_id": suite_words(registry), "tag": tag_words(registry)}


def robot_mentions(text: str) -> tuple[str, list[str]]:
    """The robots ``text`` names, in the order of the robot registry, and the text without their
    names (with "with the ... arm" around them); ``text`` is lower case."""
    robots: list[str] = []
    for robot, names in robot_words().items():
        for name in names:  # longest first
            if phrase_pattern(name).search(text) is None:
                continue
            if robot not in robots:
                robots.append(robot)
            around = re.compile(rf"(?<![\w-]){ROBOT_AROUND.format(name=re.escape(name))}(?![\w-])")
            text = around.sub(" ", text)
    return text, robots
