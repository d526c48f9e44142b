"""The words a description may use: object kinds and their synonyms, actions, parts, fillers,
polite forms, sequence words and what cannot be simulated, read from ``vocabulary.yaml`` in the
asset library (and from each ``PIPETTE_ASSET_PATH`` root that has one).

Each asset belongs to one or more *kinds* (``conical tube``, ``tube rack``, ``balance``...). A
kind has the phrases people use for it ("falcon tube", "eppendorf", "scale") and a default member
for when the description gives no size. Sizes ("15 mL", "90 mm", "96-well", "P200", "T75",
"8-channel", "16 x 150 mm") become *size tags* compared with tags derived from each asset's id
and semantics (``volume_ml``, ``volume_ul``, ``channels``, rows x cols).
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, model_validator

from pipette_cli.assets.library import ASSET_PATH_ENV, load_asset_library
from pipette_cli.errors import SpecError
from pipette_cli.language.mentions import Name, names_in
from pipette_cli.language.phrases import singular
from pipette_cli.resources import data_dir, env_paths
from pipette_cli.specs.base import Spec
from pipette_cli.specs.yaml_io import read_spec

VOCABULARY_FILE = "vocabulary.yaml"
ACTIONS = ("pick", "place", "remove", "open", "close", "press", "position", "run", "tare")
Phrase = str
Relation = Literal["next_to", "left_of", "right_of", "behind", "in_front_of"]
"""Where a placement goes relative to its target, as seen from the robot (left is its left)."""


class KindSpec(Spec):
    """A family of assets and the phrases that name it."""

    aliases: list[Phrase] = Field(min_length=1)
    assets: str = Field(description="regular expression over asset ids")
    default: str | None = None


class UnsupportedSpec(Spec):
    """Something the simulator cannot do: the verbs and words that ask for it, and why not."""

    verbs: list[Phrase] = []
    words: list[Phrase] = []
    reason: str


class PluralsSpec(Spec):
    irregular: dict[str, str] = {}
    singular: list[str] = []


class PrepositionsSpec(Spec):
    source: list[Phrase]
    over: list[Phrase]
    dest: list[Phrase]
    of: list[Phrase]


class VocabularySpec(Spec):
    """The whole ``vocabulary.yaml`` (see the file's comments)."""

    kinds: dict[str, KindSpec]
    bench: list[Phrase]
    actions: dict[str, list[Phrase]]
    implied_targets: dict[Phrase, str] = {}
    purposes: dict[str, list[str]] = {}
    """A kind -> words that say what it is for ("ice bucket": cold): said in a task that uses one
    ("... into the ice bucket to keep it cold"), they are understood; elsewhere they are not."""
    runs: list[Phrase] = []
    buttons: dict[str, list[Phrase]] = {}
    colours: list[str] = []
    """Colour words an asset's description gives its buttons ("red lid-release button"): "the red
    button" is the one its description calls red."""
    parts: dict[str, list[Phrase]]
    relations: dict[Relation, list[Phrase]]
    prepositions: PrepositionsSpec
    sequence: list[Phrase]
    first: list[Phrase]
    polite: list[Phrase]
    fillers: list[str]
    articles: list[str]
    pronouns: list[Phrase]
    plurals: PluralsSpec
    modifiers: dict[Phrase, str]
    numbers: dict[Phrase, float]
    unsupported: dict[str, UnsupportedSpec]

    @model_validator(mode="after")
    def _purposes_name_kinds(self) -> VocabularySpec:
        unknown = sorted(set(self.purposes) - set(self.kinds))
        if unknown:
            raise ValueError(f"purposes names no kind: {', '.join(unknown)}")
        return self

    def preposition_roles(self) -> list[tuple[Phrase, str]]:
        """Every preposition phrase with its role (``near`` for the relations' phrases), longest first."""
        pairs = [(p, role) for role, ps in self.prepositions.model_dump().items() for p in ps]
        pairs += [(p, "near") for ps in self.relations.values() for p in ps]
        return sorted(pairs, key=lambda pr: -len(pr[0].split()))

    def relation_of(self, phrase: str | None) -> Relation | None:
        """The relation (``left_of``...) a preposition phrase names, or None."""
        return next((name for name, ps in self.relations.items() if phrase in ps), None)


class ExtraKindsSpec(Spec):
    """A user asset root's ``vocabulary.yaml``: more kinds only."""

    kinds: dict[str, KindSpec] = {}


@dataclass(frozen=True)
class Kind:
    """A family of assets and the phrases that name it."""

    name: str
    aliases: tuple[str, ...]
    pattern: str  # regex over asset ids
    default: str | None = None


SIZE_CLASSES = ("ml", "ul", "mm", "well", "channel", "p", "t", "x")


def size_class(tag: str) -> str:
    """The unit family of a size tag (``15ml`` -> ``ml``, ``p200`` -> ``p``, ``16x150`` -> ``x``)."""
    if re.fullmatch(r"\d+(\.\d+)?x\d+", tag):
        return "x"
    for cls in ("channel", "well", "ml", "ul", "mm"):
        if tag.endswith(cls):
            return cls
    return tag[0]


def _num(text: str) -> str:
    return f"{float(text.replace(',', '.').replace('_', '.')):g}"


def asset_size_tags(asset_id: str, semantics: dict[str, Any]) -> frozenset[str]:
    """Size tags of an asset from its id and semantics (``15ml``, ``90mm``, ``96well``, ``p200``...)."""
    tags: set[str] = set()
    for number, unit in re.findall(r"(\d+(?:_\d+)?)(ml|ul|mm)(?![a-z])", asset_id):
        tags.add(_num(number) + unit)
    m = re.search(r"_(\d+)x(\d+)$", asset_id)
    if m:
        tags.add(f"{m.group(1)}x{m.group(2)}")
        tags.add(f"{m.group(1)}mm")
    m = re.search(r"_t(\d+)$", asset_id)
    if m:
        tags.add(f"t{m.group(1)}")
    if semantics.get("volume_ml") is not None:
        tags.add(f"{float(semantics['volume_ml']):g}ml")
    if semantics.get("volume_ul") is not None:
        ul = float(semantics["volume_ul"])
        tags.add(f"{ul:g}ul")
        if ul >= 1000:
            tags.add(f"{ul / 1000:g}ml")
    if semantics.get("rows") and semantics.get("cols"):
        tags.add(f"{int(semantics['rows'] * semantics['cols'])}well")
    if semantics.get("channels") and asset_id.startswith(("pipette", "reservoir")):
        tags.add(f"{int(semantics['channels'])}channel")
    if asset_id.startswith("pipette_single_channel") and semantics.get("volume_ul"):
        tags.add(f"p{int(semantics['volume_ul'])}")
    return frozenset(tags)


def _words(text: str) -> set[str]:
    return set(re.findall(r"[a-z0-9]+", text.lower()))


@dataclass(frozen=True)
class AssetInfo:
    """What the parser knows about one asset without compiling it."""

    asset_id: str
    category: str
    semantics: dict[str, Any]
    kinds: tuple[str, ...]
    size_tags: frozenset[str]
    words: frozenset[str]

    @property
    def graspable(self) -> bool:
        return bool(self.semantics.get("graspable")) and not self.semantics.get("static", False)

    @property
    def static(self) -> bool:
        return bool(self.semantics.get("static"))

    @property
    def description(self) -> str:
        return str(self.semantics.get("description", ""))

    def human_name(self) -> str:
        """``15 mL conical tube`` for ``conical_tube_15ml``: the words a person would use."""
        name = self.kinds[0] if self.kinds else self.asset_id.replace("_", " ")
        digits = set(re.findall(r"\d+", self.asset_id.replace("1_5", "1.5").replace("0_2", "0.2")))
        named = [
            t
            for t in self.size_tags
            if (re.match(r"[\d.]+|[pt](\d+)", t) or [""])[0].lstrip("pt") in digits
            or t in self.asset_id.replace("_", ".")
        ]
        order = ("well", "channel", "ml", "ul", "mm", "p", "t", "x")
        named.sort(key=lambda t: order.index(size_class(t)))
        if not named:
            return name
        tag = named[0]
        if size_class(tag) == "well" and name.endswith("well plate"):
            return f"{tag[:-4]}-{name}"
        return f"{_pretty_size(tag)} {name}"


def _pretty_size(tag: str) -> str:
    for unit, shown in (("ml", "mL"), ("ul", "uL"), ("mm", "mm")):
        if tag.endswith(unit):
            return tag[: -len(unit)] + " " + shown
    if tag.endswith("well"):
        return tag[:-4] + "-well"
    if tag.endswith("channel"):
        return tag[:-7] + "-channel"
    if tag.startswith(("p", "t")):
        return tag.upper()
    return tag


@dataclass
class Vocabulary:
    """Every asset with its kinds, size tags and words; alias phrases to kinds; the sentence words."""

    assets: dict[str, AssetInfo]
    kinds: dict[str, Kind]
    words: VocabularySpec
    alias_to_kind: dict[str, str] = field(default_factory=dict)

    def lid_owner(self, asset: str) -> str | None:
        """The instrument whose lift-off lid ``asset`` is (its description names the lid a separate asset)."""
        for owner, info in self.assets.items():
            m = re.search(r"separate asset (\w+)", info.description)
            if m and m.group(1) == asset:
                return owner
        return None

    def has_part(self, kind: str, part: str) -> bool:
        """Whether a member of ``kind`` has the part ``part`` (a vocabulary part name: ``shelf_1``,
        ``shelf``, ``door``): a site, joint or body whose name starts with it (``shelf_1_center``)."""
        for asset in self.members(kind):
            semantics = self.assets[asset].semantics
            names = [*semantics.get("sites", []), *semantics.get("joints", []), *semantics.get("bodies", [])]
            if any(str(n) == part or str(n).startswith(f"{part}_") for n in names):
                return True
        return False

    def describes(self, word: str, kind: str) -> bool:
        """Whether ``word`` describes a member of ``kind`` (a word of its id or its description)."""
        return any(word in self.assets[a].words for a in self.members(kind))

    def members(self, kind: str) -> list[str]:
        return [a for a, info in self.assets.items() if kind in info.kinds]

    def aliases(self) -> list[str]:
        """Alias phrases, longest first (for greedy matching)."""
        return sorted(self.alias_to_kind, key=lambda a: (-len(a.split()), -len(a), a))

    def lemma(self, word: str) -> str:
        """A word's singular form by this vocabulary's plural rules."""
        return singular(word, self.words.plurals.irregular, self.words.plurals.singular)

    def names_in(self, text: str) -> list[tuple[Name, str]]:
        """The asset names ``text`` holds, each with its kind, whole before their parts
        (:func:`~pipette_cli.language.mentions.names_in`: "pipette tip box" is one tip box)."""
        return [(name, self.alias_to_kind[name.phrase]) for name in names_in(text, self.aliases(), self.lemma)]

    def nearest(self, phrase: str, n: int = 3) -> list[str]:
        """Names closest to an unknown phrase: kind names by spelling, then by shared words."""
        phrase = phrase.lower().strip()
        scored: dict[str, float] = {}
        for alias in difflib.get_close_matches(phrase, list(self.alias_to_kind), n=6, cutoff=0.6):
            kind = self.alias_to_kind[alias]
            scored[kind] = max(scored.get(kind, 0.0), 1.0 + difflib.SequenceMatcher(None, phrase, alias).ratio())
        for word in _words(phrase):
            for alias in difflib.get_close_matches(word, list(self.alias_to_kind), n=3, cutoff=0.75):
                kind = self.alias_to_kind[alias]
                scored[kind] = max(scored.get(kind, 0.0), 0.5 + difflib.SequenceMatcher(None, word, alias).ratio() / 2)
        query = _words(phrase)
        for info in self.assets.values():
            overlap = len(query & info.words)
            if overlap and info.kinds:
                scored[info.kinds[0]] = max(scored.get(info.kinds[0], 0.0), 0.3 * overlap)
        return [k for k, _ in sorted(scored.items(), key=lambda kv: (-kv[1], kv[0]))[:n]]

    def closest(self, phrase: str, n: int = 3) -> list[str]:
        """Asset ids closest to an unknown phrase (the defaults of :meth:`nearest`'s kinds, then ids)."""
        out: list[str] = []
        for kind in self.nearest(phrase, n):
            default = self.kinds[kind].default
            out += [default] if default else self.members(kind)[:1]
        for asset_id in difflib.get_close_matches(phrase.replace(" ", "_"), list(self.assets), n=n, cutoff=0.5):
            if asset_id not in out:
                out.append(asset_id)
        return out[:n]


def vocabulary_files() -> list[Path]:
    """The built-in ``vocabulary.yaml`` and those of the user asset roots that have one."""
    files = [data_dir("assets") / VOCABULARY_FILE]
    files += [p / VOCABULARY_FILE for p in env_paths(ASSET_PATH_ENV) if (p / VOCABULARY_FILE).is_file()]
    return files


def load_vocabulary_spec() -> VocabularySpec:
    """Read and validate the vocabulary files (user kinds are added after the built-in ones).

    Raises:
        SpecError: ``file:line: field: message`` for each problem.
    """
    built_in, *extra = vocabulary_files()
    spec = read_spec(built_in, VocabularySpec)
    kinds = dict(spec.kinds)
    for path in extra:
        for name, kind in read_spec(path, ExtraKindsSpec).kinds.items():
            kinds.setdefault(name, kind)
    return spec.model_copy(update={"kinds": kinds})


@cache
def load_vocabulary() -> Vocabulary:
    """The vocabulary of the current asset library (reads every asset's semantics once).

    Raises:
        SpecError: a vocabulary file is malformed, or names a kind pattern that is not a regex.
    """
    words = load_vocabulary_spec()
    library = load_asset_library()
    kinds: dict[str, Kind] = {}
    for name, k in words.kinds.items():
        try:
            re.compile(k.assets)
        except re.error as exc:
            raise SpecError(
                f"vocabulary kinds.{name}.assets: {k.assets!r} is not a regular expression ({exc})"
            ) from None
        default = k.default if k.default in library.entries else None
        kinds[name] = Kind(name, tuple(k.aliases), k.assets, default)
    assets: dict[str, AssetInfo] = {}
    for entry in library.entries.values():
        if entry.asset_id == "lab_bench":
            continue
        semantics = entry.semantics()
        member_of = tuple(k.name for k in kinds.values() if re.search(k.pattern, entry.asset_id))
        text = entry.asset_id.replace("_", " ") + " " + str(semantics.get("description", ""))
        assets[entry.asset_id] = AssetInfo(
            entry.asset_id,
            entry.category,
            semantics,
            member_of,
            asset_size_tags(entry.asset_id, semantics),
            frozenset(_words(text)),
        )
    alias_to_kind: dict[str, str] = {}
    for kind in kinds.values():
        for alias in kind.aliases:
            alias_to_kind.setdefault(alias, kind.name)
    # assets no kind covers (user assets on PIPETTE_ASSET_PATH) are named by their id's words
    for asset_id, info in list(assets.items()):
        if not info.kinds:
            name = asset_id.replace("_", " ")
            kinds[name] = Kind(name, (name,), rf"^{re.escape(asset_id)}$", asset_id)
            alias_to_kind.setdefault(name, name)
            assets[asset_id] = AssetInfo(asset_id, info.category, info.semantics, (name,), info.size_tags, info.words)
    return Vocabulary(assets, kinds, words, alias_to_kind)
