"""Which asset a mention means: its kind's members narrowed by the sizes and words said, plain
variants first, the kind's default on a tie; an item and the holder it goes into are chosen
together so the item fits the holder's holes ("the 15 mL tube in the rack" -> the 15 mL rack).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pipette_cli.language.assets import Vocabulary, size_class
from pipette_cli.taskgen.plan import PlanError

VARIANTS = ("nocap", "open", "skirted", "quartz", "large", "small", "carousel", "linear", "deep")
"""Id words of variants a description must ask for ("uncapped", "skirted", "quartz"...)."""
FIT_PLAY = 0.0002
"""Metres an item must be narrower than a hole to go in."""


@dataclass(frozen=True)
class Wanted:
    """What a mention asks for: a kind, size tags and descriptive words."""

    kind: str
    sizes: tuple[str, ...] = ()
    modifiers: tuple[str, ...] = ()

    def words(self) -> str:
        return " ".join([*self.sizes, *self.modifiers, self.kind])


def candidates(vocab: Vocabulary, wanted: Wanted) -> list[str]:
    """Assets of ``wanted.kind`` with every size said, best first.

    Raises:
        PlanError: a size no member has ("no 3ml beaker ...; beaker sizes: ...").
    """
    members = vocab.members(wanted.kind)
    kind = vocab.kinds[wanted.kind]
    for tag in wanted.sizes:
        keep = [a for a in members if tag in vocab.assets[a].size_tags]
        if not keep:
            same = sorted({t for a in members for t in vocab.assets[a].size_tags if size_class(t) == size_class(tag)})
            if not same and size_class(tag) in ("ml", "mm", "ul"):
                continue  # sizes the kind does not vary by (a "250 mL" pipette stand) carry no choice
            sizes = ", ".join(same) if same else "no sizes"
            raise PlanError(
                f"no {tag} {kind.name} in the asset library ({kind.name} sizes: {sizes}); pick one of "
                f'those, or make it with `pipette assets new "a {tag} {kind.name}"`'
            )
        members = keep
    wanted_words = set(wanted.modifiers)
    extreme = next((w for w in ("smallest", "largest") if w in wanted_words), None)
    sized = {a: capacity(vocab, a) for a in members} if extreme else {}
    volumes = {a: v for a, v in sized.items() if v is not None and v[0] == "ml"}  # volume before length
    known = volumes or {a: v for a, v in sized.items() if v is not None}
    if known:  # "the smallest beaker": the member of least (or most) capacity, whatever else is said
        goal = (min if extreme == "smallest" else max)(v[1] for v in known.values())
        members = [a for a in known if known[a][1] == goal]
    scored = []
    for a in members:
        info = vocab.assets[a]
        id_words = set(a.split("_"))
        score: float = len(wanted_words & (info.words | id_words))
        score -= sum(1 for v in VARIANTS if v in id_words and v not in wanted_words)  # plain variants first
        score += 0.5 if a == kind.default else 0.0
        scored.append((-score, a))
    return [a for _, a in sorted(scored)]


def capacity(vocab: Vocabulary, asset: str) -> tuple[str, float] | None:
    """An asset's size from its size tags: ``("ml", volume)``, else ``("mm", length)``."""
    found = []
    for tag in vocab.assets[asset].size_tags:
        m = re.fullmatch(r"(\d+(?:\.\d+)?)(ml|ul|mm)", tag)
        if m:
            found.append(("ml", float(m[1]) / 1000.0) if m[2] == "ul" else (m[2], float(m[1])))
    return min(found, key=lambda f: f[0] != "ml", default=None)


def hole(vocab: Vocabulary, holder: str) -> float | None:
    sem = vocab.assets[holder].semantics
    return float(sem["hole"]) if "hole" in sem else None


def diameter(vocab: Vocabulary, item: str) -> float | None:
    sem = vocab.assets[item].semantics
    for key in ("outer_diameter", "base_diameter", "diameter"):
        if key in sem:
            return float(sem[key])
    return None


def fits(vocab: Vocabulary, item: str, holder: str) -> bool | None:
    """Whether ``item`` fits the holes of ``holder`` (None when the holder has no holes)."""
    h, d = hole(vocab, holder), diameter(vocab, item)
    if h is None or d is None:
        return None
    return d + FIT_PLAY <= h


def _affinity(vocab: Vocabulary, item: str, holder: str) -> int:
    """Shared size tags and id words: a 15 mL conical tube belongs in the 15 mL conical tube rack."""
    a, b = vocab.assets[item], vocab.assets[holder]
    return 2 * len(a.size_tags & b.size_tags) + len((set(item.split("_")) & set(holder.split("_"))) - {"tube"})


def _slack(vocab: Vocabulary, item: str, holder: str) -> float:
    h, d = hole(vocab, holder), diameter(vocab, item)
    return (h - d) if h is not None and d is not None else 1.0


def choose_pair(vocab: Vocabulary, items: list[str], holders: list[str]) -> tuple[str, str]:
    """The best (item, holder) of two candidate lists: fitting first, then the items' order, then
    matching sizes, then the holders' order, then the tightest fit."""
    pairs = [(i, h) for i in items for h in holders]
    fitting = [p for p in pairs if fits(vocab, *p) is not False] or pairs
    return min(
        fitting, key=lambda p: (items.index(p[0]), -_affinity(vocab, *p), holders.index(p[1]), _slack(vocab, *p))
    )


def holders_that_fit(vocab: Vocabulary, item: str) -> list[str]:
    d = diameter(vocab, item)
    if d is None:
        return []
    return sorted(a for a in vocab.assets if (h := hole(vocab, a)) is not None and h >= d + FIT_PLAY)
