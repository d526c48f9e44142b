"""The offline backend's parser: an English description -> :class:`TaskDraftSpec`.

Deterministic and small: object mentions are found by the vocabulary's alias phrases
(longest first) with the sizes and adjectives around them; the intent comes from the verbs
and the prepositions that link the mentions ("into" the rack, "from" the balance, "over" the
dish); roles follow from those prepositions. Words that name nothing known make the parse
fail with the closest assets, rather than being ignored.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from pipette_cli.authoring.draft import DraftError, DraftObjectSpec, DraftThresholdsSpec, TaskDraftSpec
from pipette_cli.authoring.vocabulary import BENCH_WORDS, Vocabulary, size_class
from pipette_cli.specs.robot import load_robot_specs

VERBS: dict[str, tuple[str, ...]] = {
    "transfer": ("transfer", "relocate", "remove", "unload", "retrieve", "take out", "take off", "move from"),
    "position": ("position", "hover", "align", "point"),
    "insert": ("insert", "slot", "plug", "hang", "dock", "rack", "stick"),
    "open": ("open", "unlatch", "pull out", "pull open", "swing open", "flip open"),
    "close": ("close", "shut", "push in", "push shut", "swing shut", "flip shut"),
    "press": ("press", "push", "hit", "tap", "activate", "trigger", "click", "actuate", "start"),
    "place": ("place", "put", "set", "stand", "lay", "load", "move", "bring", "return", "deposit", "drop", "carry",
              "rest", "slide", "transport", "deliver", "put back", "set down", "hold"),
    "pick": ("pick up", "pick", "lift", "grab", "grasp", "raise", "take", "get", "collect", "fetch", "lower"),
}
PREPOSITIONS: dict[str, tuple[str, ...]] = {
    "near": ("next to", "beside", "near", "close to", "in front of", "behind", "alongside", "by"),
    "source": ("out of", "off of", "away from", "from", "off"),
    "over": ("over", "above", "right above", "on top of"),
    "dest": ("into", "inside", "onto", "on to", "in to", "in", "on", "to", "toward", "towards", "at", "back in", "back on"),
    "of": ("of",),
}
PART_WORDS = {
    "lid": "lid", "cover": "lid", "door": "door", "drawer": "drawer", "sash": "sash", "button": "button",
    "release button": "button", "knob": "knob", "pan": "pan", "platform": "platform", "top shelf": "shelf_1",
    "upper shelf": "shelf_1", "bottom shelf": "shelf_0", "lower shelf": "shelf_0", "shelf": "shelf",
    "slot": "slot", "compartment": "slot", "rotor": "rotor", "block": "block", "cup": "cup", "seat": "seat",
    "tray": "drawer", "carrier": "drawer", "well": "slot", "hole": "slot", "position": "slot",
}
ARTICLES = {"the", "a", "an", "this", "that", "its", "their", "one", "some", "each", "my", "our", "his", "her"}
FILLERS = {
    "please", "robot", "arm", "gripper", "it", "them", "then", "and", "carefully", "gently", "slowly", "quickly",
    "firmly", "safely", "steadily", "steady", "so", "that", "is", "are", "be", "stays", "stay", "remains", "remain",
    "fully", "all", "way", "completely", "empty", "full", "clean", "sterile", "new", "fresh", "used", "sample",
    "samples", "with", "using", "up", "down", "back", "there", "again", "just", "free", "standing", "lying", "flat",
    "upright", "vertical", "vertically", "position", "left", "right", "front", "side", "far", "end", "available",
    "open", "opened", "closed", "shut", "without", "tilting", "spilling", "dropping", "it's", "keep", "keeping", "make",
    "sure", "for", "while", "then", "after", "before", "first", "finally", "out", "off", "in", "into", "place", "spot",
    "lab", "lab's", "bench's", "top", "surface", "s", "can", "you", "will", "should", "must", "to", "let", "go",
    "release", "bottom", "middle", "center", "centre", "inside", "onto", "over", "above", "within", "seconds", "area",
    "i", "we", "want", "need", "would", "like", "robot's", "empty", "half", "filled", "single", "channel", "upper",
    "lower", "handle", "by", "from", "at", "on", "of", "the", "a", "an", "could", "would", "kindly", "now", "me",
    "here", "i'd", "we'd", "hand", "wait", "done", "task",
}
MODIFIER_SYNONYMS = {"uncapped": "nocap", "capless": "nocap", "decapped": "nocap", "self-standing": "skirted",
                     "selfstanding": "skirted", "opened": "open", "big": "large", "little": "small", "mini": "small",
                     "disposable": "disposable", "plastic": "ps"}
SIZE_PATTERNS: tuple[tuple[str, object], ...] = (
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
THRESHOLD_PATTERNS: tuple[tuple[str, str, float], ...] = (
    # (regex, field, scale); the first group is the number
    (r"\b(?:by|at least|to a height of|a height of|lift(?:ed)? it|raise(?:d)? it)\s+(\d+(?:\.\d+)?)\s*cm\b", "lift_height_m", 0.01),
    (r"\b(?:by|at least|to a height of|a height of)\s+(\d+(?:\.\d+)?)\s*mm\b", "lift_height_m", 0.001),
    (r"\bfor\s+(?:at least\s+)?(\d+(?:\.\d+)?)\s*(?:s|secs?|seconds?)\b", "hold_s", 1.0),
    (r"\b(?:within|in under|in less than|under|in)\s+(\d+(?:\.\d+)?)\s*(?:s|secs?|seconds?)\b", "timeout_s", 1.0),
    (r"\b(?:within|in under|in less than|under|in)\s+(\d+(?:\.\d+)?)\s*(?:min|mins|minutes?)\b", "timeout_s", 60.0),
    (r"\btilt(?:ing|ed)?\s+(?:it\s+)?(?:more than|over|by more than|beyond|past)\s+(\d+(?:\.\d+)?)\s*(?:deg|degrees?)\b", "max_tilt_deg", 1.0),
    (r"\bwithin\s+(\d+(?:\.\d+)?)\s*cm\s+of\b", "xy_tolerance_m", 0.01),
    (r"\bwithin\s+(\d+(?:\.\d+)?)\s*mm\s+of\b", "xy_tolerance_m", 0.001),
)


@dataclass
class Token:
    text: str
    kind: str = "word"  # word | size | punct
    used: bool = False


@dataclass
class Mention:
    start: int
    end: int  # exclusive, alias end
    kind: str
    phrase: str
    sizes: list[str] = field(default_factory=list)
    modifiers: list[str] = field(default_factory=list)
    window_start: int = 0
    prep: str | None = None  # near | source | over | dest | None (direct object)
    part: str | None = None
    is_bench: bool = False
    asset: str | None = None
    part_before: bool = False


@dataclass
class ParseResult:
    """The draft and the remarks that become VERIFY comments (choices among equals)."""

    draft: TaskDraftSpec
    remarks: list[str]


def _normalise(text: str) -> str:
    s = text.lower().replace("µ", "u").replace("μ", "u").replace("×", "x").replace("’", "'").replace("°", " deg")
    s = re.sub(r"(\d),(\d{3})\b", r"\1\2", s)  # 1,000 -> 1000
    s = re.sub(r"without (?:its |a |the )?caps?\b|\bno caps?\b|\bcap(?:ped)? off\b", " nocap ", s)
    s = re.sub(r"\bself[- ]standing\b", " skirted ", s)
    s = re.sub(r"(?<=[a-z])-(?=[a-z])", " ", s)  # multi-channel -> multi channel
    s = re.sub(r"(?<=\d)-(?=[a-z])|(?<=[a-z])-(?=\d)", " ", s)  # 96-well, t-75
    s = s.replace("'s ", " ")
    return s


def _extract_thresholds(text: str) -> tuple[str, dict[str, float]]:
    found: dict[str, float] = {}
    for pattern, name, scale in THRESHOLD_PATTERNS:
        for m in re.finditer(pattern, text):
            if name not in found:
                found[name] = round(float(m.group(1)) * scale, 6)
            text = text[: m.start()] + " " * (m.end() - m.start()) + text[m.end():]
    if re.search(r"\b(upright|without tilting|not tilt|keep(?:ing)? it level|level)\b", text) and "max_tilt_deg" not in found:
        found["max_tilt_deg"] = 15.0
    return text, found


def robot_words() -> dict[str, list[str]]:
    """Phrases naming each robot in a description (``words`` of ``registry/robots/*.yaml``)."""
    return {name: spec.words for name, spec in load_robot_specs().items()}


def _extract_robots(text: str) -> tuple[str, list[str]]:
    robots: list[str] = []
    for robot, words in robot_words().items():
        for word in words:
            pattern = rf"\b(?:with|using|by)?\s*(?:the\s+)?{re.escape(word)}(?:\s+(?:arm|robot))?\b"
            if re.search(rf"\b{re.escape(word)}\b", text):
                if robot not in robots:
                    robots.append(robot)
                text = re.sub(pattern, " ", text)
    return text, robots


def _tokenise(text: str) -> list[Token]:
    spans: list[tuple[int, int, list[str]]] = []
    for pattern, make in SIZE_PATTERNS:
        for m in re.finditer(pattern, text):
            if any(s < m.end() and m.start() < e for s, e, _ in spans):
                continue
            spans.append((m.start(), m.end(), make(m)))  # type: ignore[operator]
    spans.sort()
    tokens: list[Token] = []
    pos = 0
    for start, end, tags in [*spans, (len(text), len(text), [])]:
        for word in re.findall(r"[a-z0-9][a-z0-9']*|[,.;!?]", text[pos:start]):
            tokens.append(Token(word, "punct" if word in ",.;!?" else "word"))
        for tag in tags:
            tokens.append(Token(tag, "size"))
        pos = end
    return tokens


def _match_phrase(tokens: list[Token], i: int, phrase: str) -> int:
    """Tokens consumed by ``phrase`` at position ``i`` (0 when it does not match there)."""
    words = phrase.split()
    if i + len(words) > len(tokens):
        return 0
    for k, word in enumerate(words):
        if tokens[i + k].kind != "word" or tokens[i + k].text != word:
            return 0
    return len(words)


def _verb_words() -> set[str]:
    return {v.split()[0] for verbs in VERBS.values() for v in verbs}


class DescriptionParser:
    """Parses descriptions against one vocabulary."""

    def __init__(self, vocabulary: Vocabulary) -> None:
        self.vocab = vocabulary
        self._aliases = vocabulary.aliases()
        self._verbs = _verb_words()

    # ----------------------------------------------------------------------- public
    def parse(self, description: str) -> ParseResult:
        """Parse ``description``.

        Raises:
            DraftError: unknown objects (with the closest assets), contradictions, missing parts.
        """
        text = _normalise(description)
        if re.search(r"\b(don't|dont|do not|never|must not|mustn't|should not|shouldn't)\b", text):
            raise DraftError("negations are not supported: describe what the robot should do, e.g. 'Close the centrifuge lid'")
        text, thresholds = _extract_thresholds(text)
        text, robots = _extract_robots(text)
        if len(robots) > 1:
            raise DraftError(f"contradictory request: it names {len(robots)} robots ({', '.join(robots)}); a task has one")
        tokens = _tokenise(text)
        verbs = self._find_verbs(tokens)
        mentions = self._find_mentions(tokens, verbs)
        self._attach_sizes_and_modifiers(tokens, mentions, verbs)
        parts = self._find_parts(tokens, mentions)
        self._assign_prepositions(tokens, mentions, verbs, parts)
        unknown = self._unknown_phrases(tokens)
        intent = self._intent(verbs, mentions, parts, tokens)
        objects, remarks = self._roles(intent, mentions, parts, unknown, description)
        instruction = instruction_from(description)
        try:
            draft = TaskDraftSpec(intent=intent, objects=objects, robot=robots[0] if robots else None,  # type: ignore[arg-type]
                                  instruction=instruction, thresholds=DraftThresholdsSpec(**thresholds))
        except ValueError as exc:
            raise DraftError(f"could not make a task of {description!r}: {exc}") from None
        return ParseResult(draft, remarks)

    # ----------------------------------------------------------------------- steps
    def _find_verbs(self, tokens: list[Token]) -> list[tuple[int, int, str, str]]:
        """(start, end, intent, verb phrase) for every verb; longest phrase first at each position."""
        table = sorted(((v, intent) for intent, vs in VERBS.items() for v in vs), key=lambda p: -len(p[0].split()))
        found = []
        i = 0
        while i < len(tokens):
            for phrase, intent in table:
                n = _match_phrase(tokens, i, phrase)
                if n:
                    found.append((i, i + n, intent, phrase))
                    i += n - 1
                    break
            i += 1
        return found

    def _find_mentions(self, tokens: list[Token], verbs) -> list[Mention]:
        verb_at = {start: end for start, end, _, _ in verbs}
        mentions: list[Mention] = []
        i = 0
        while i < len(tokens):
            matched = False
            for alias in [*self._aliases, *BENCH_WORDS]:
                n = _match_phrase(tokens, i, alias)
                if not n:
                    continue
                single_verb = n == 1 and tokens[i].text in self._verbs and (i in verb_at)
                previous = tokens[i - 1].text if i else ""
                if single_verb and previous not in ARTICLES:
                    continue  # "slide the drawer" is a verb, "the slide" a noun
                if alias in PART_WORDS and previous in ("the", "its") and any(m.end == i for m in mentions):
                    continue
                kind = self.vocab.alias_to_kind.get(alias, "bench")
                mentions.append(Mention(i, i + n, kind, alias, is_bench=alias in BENCH_WORDS and alias not in self.vocab.alias_to_kind))
                for k in range(i, i + n):
                    tokens[k].used = True
                i += n
                matched = True
                break
            if not matched:
                i += 1
        for start, end, _, _ in verbs:
            if not any(m.start <= start < m.end for m in mentions):
                for k in range(start, end):
                    tokens[k].used = True
        return mentions

    def _attach_sizes_and_modifiers(self, tokens: list[Token], mentions: list[Mention], verbs) -> None:
        stops = {"punct"}
        verb_tokens = {k for s, e, _, _ in verbs for k in range(s, e)}
        prep_words = {w for ps in PREPOSITIONS.values() for p in ps for w in p.split()}
        for index, m in enumerate(mentions):
            floor = mentions[index - 1].end if index else 0
            k = m.start - 1
            while k >= floor and tokens[k].kind not in stops and k not in verb_tokens and tokens[k].text not in ARTICLES \
                    and (tokens[k].kind == "size" or tokens[k].text not in prep_words):
                if tokens[k].kind == "size":
                    m.sizes.append(tokens[k].text)
                elif not tokens[k].used:
                    m.modifiers.append(MODIFIER_SYNONYMS.get(tokens[k].text, tokens[k].text))
                tokens[k].used = True
                k -= 1
            m.window_start = k + 1
            ceiling = mentions[index + 1].start if index + 1 < len(mentions) else len(tokens)
            k = m.end
            while k < min(ceiling, m.end + 3) and tokens[k].kind != "punct":
                if tokens[k].kind == "size" and not tokens[k].used:
                    m.sizes.append(tokens[k].text)
                    tokens[k].used = True
                elif tokens[k].text in ("nocap", "skirted", "open", "capped"):
                    m.modifiers.append(tokens[k].text)
                    tokens[k].used = True
                elif tokens[k].text not in ("with", "of", "(", ")"):
                    break
                k += 1

    def _find_parts(self, tokens: list[Token], mentions: list[Mention]) -> list[tuple[int, int, str, Mention | None]]:
        parts = []
        phrases = sorted(PART_WORDS, key=lambda p: -len(p.split()))
        i = 0
        while i < len(tokens):
            if tokens[i].used and tokens[i].kind == "word" and not any(m.start <= i < m.end for m in mentions):
                pass
            if any(m.start <= i < m.end for m in mentions):
                i += 1
                continue
            for phrase in phrases:
                n = _match_phrase(tokens, i, phrase)
                if not n:
                    continue
                owner = None
                nxt = next((m for m in mentions if m.start >= i + n), None)
                prev = next((m for m in reversed(mentions) if m.end <= i), None)
                link = {"of", "on", "in", "at", "off", "from", "inside", "onto"}
                between = [t.text for t in tokens[i + n : nxt.window_start] if t.text != "back"] if nxt is not None else []
                if prev is not None and all(t.text in ARTICLES for t in tokens[prev.end : i]):
                    owner = prev  # "the centrifuge lid", "the incubator's door"
                elif nxt is not None and between and between[0] in link and all(w in ARTICLES for w in between[1:]):
                    owner = nxt  # "the lid of the centrifuge", "the button on the centrifuge"
                    for k in range(i + n, nxt.window_start):
                        tokens[k].used = True
                    owner.part_before = True
                parts.append((i, i + n, PART_WORDS[phrase], owner))
                for k in range(i, i + n):
                    tokens[k].used = True
                if owner is not None:
                    owner.part = PART_WORDS[phrase]
                i += n - 1
                break
            i += 1
        return parts

    def _assign_prepositions(self, tokens: list[Token], mentions: list[Mention], verbs, parts) -> None:
        table = sorted(((p, role) for role, ps in PREPOSITIONS.items() for p in ps), key=lambda x: -len(x[0].split()))
        anchors = sorted([(e, "verb") for _, e, _, _ in verbs] + [(m.end, "mention") for m in mentions] + [(e, "part") for _, e, _, _ in parts])

        def prep_before(position: int) -> tuple[str | None, int]:
            floor = max([a for a, _ in anchors if a <= position] or [0])
            found: tuple[str | None, int] = (None, -1)
            k = floor
            while k < position:
                for phrase, role in table:
                    n = _match_phrase(tokens, k, phrase)
                    if n and k + n <= position:
                        found = (role, k)
                        for j in range(k, k + n):
                            tokens[j].used = True
                        k += n - 1
                        break
                k += 1
            return found

        for m in mentions:
            owned = [p for p in parts if p[3] is m and p[0] < m.start and m.part_before]
            start = owned[0][0] if owned else m.window_start
            m.prep = prep_before(start)[0]
            if m.prep == "of":
                m.prep = None

    def _unknown_phrases(self, tokens: list[Token]) -> list[str]:
        phrases: list[str] = []
        current: list[str] = []
        for token in tokens:
            unknown = token.kind == "word" and not token.used and token.text not in FILLERS and token.text not in ARTICLES \
                and not token.text.isdigit()
            if unknown:
                current.append(token.text)
            elif current:
                phrases.append(" ".join(current))
                current = []
        if current:
            phrases.append(" ".join(current))
        return phrases

    def _intent(self, verbs, mentions: list[Mention], parts, tokens: list[Token]) -> str:
        found = [intent for _, _, intent, _ in verbs]
        phrases = [phrase for _, _, _, phrase in verbs]
        part_names = {p[2] for p in parts}
        preps = {m.prep for m in mentions}
        hatch = [i for i in found if i in ("open", "close", "press")]
        text = " ".join(t.text for t in tokens)
        if "press" in hatch and "button" not in part_names and not any(
            self._has_site(m, "button") for m in mentions if m.prep is None
        ):
            hatch = [h for h in hatch if h != "press"]
            if "push" in phrases and ("drawer" in part_names or re.search(r"\bpush\w* .* (in|shut|closed)\b", text)):
                hatch.append("close")
        if {"lid", "drawer", "door", "sash"} & part_names:
            if re.search(r"\b(lift|raise|take off|remove|pull out|pull)\b", text) and not hatch:
                hatch.append("open")
            if re.search(r"\b(lower)\b", text) and not hatch:
                hatch.append("close")
        if re.search(r"\b(closed|shut)\s*[.!]?$", text) and not hatch and ({"lid", "drawer", "door", "sash"} & part_names or "slide" in phrases):
            hatch.append("close")
        lid_owner = next((owner for _, _, part, owner in parts if part == "lid" and owner is not None), None)
        if lid_owner is not None and not hatch and any(i in ("place", "pick") for i in found) and re.search(
                r"separate asset", " ".join(self.vocab.assets[a].description for a in self.vocab.members(lid_owner.kind))):
            hatch.append("open" if re.search(r"\b(lift|raise|take off|remove|pull)\b", text) else "close")
        if set(hatch) >= {"open", "close"}:
            raise DraftError("contradictory request: it asks to both open and close; describe one of them")
        if "press" in hatch and "close" in hatch:
            raise DraftError("contradictory request: pressing the release button opens the lid, it cannot close it")
        movers = [i for i in found if i not in ("open", "close", "press")]
        objects = [m for m in mentions if not m.is_bench]
        if hatch and (any(m.prep in ("dest", "over") for m in mentions)
                      or (any(i in ("place", "insert", "transfer", "position") for i in movers) and len(objects) > 1)):
            raise DraftError(
                f"the description holds two tasks ({hatch[0]} and {movers[0] if movers else 'place'}); "
                "draft one task at a time, e.g. the placement with the instrument already open"
            )
        if hatch:
            return "press" if "press" in hatch else hatch[0]
        if "transfer" in found and "dest" not in preps and "source" not in preps and found == ["transfer"]:
            raise DraftError("a transfer needs a source: say where the object is taken from ('from the balance')")
        if "transfer" in found or ("source" in preps and "dest" in preps):
            return "transfer"
        if "position" in found or ("over" in preps and "insert" not in found):
            return "position"
        if "insert" in found:
            return "insert"
        if "dest" in preps:
            dest = next(m for m in mentions if m.prep == "dest")
            return "insert" if self._is_holder(dest) else "place"
        if "source" in preps and any(p in phrases for p in ("take", "move", "lower", "bring", "carry")):
            return "transfer"
        if "pick" in found or "place" in found:
            return "pick"
        raise DraftError(
            "no action found: start with a verb such as 'pick up', 'place', 'insert', 'open', 'close', "
            "'press', 'transfer' or 'position'"
        )

    def _has_site(self, m: Mention, site: str) -> bool:
        candidates = self.vocab.members(m.kind) if not m.is_bench else []
        return any(site in self.vocab.assets[a].semantics.get("sites", []) for a in candidates)

    def _is_holder(self, m: Mention) -> bool:
        if m.is_bench:
            return False
        return any(
            any(s.startswith("slot_") for s in self.vocab.assets[a].semantics.get("sites", []))
            or {"cuvette_slot", "rotor_center", "cup_center", "block_center"} & set(self.vocab.assets[a].semantics.get("sites", []))
            for a in self.vocab.members(m.kind)
        )

    # ----------------------------------------------------------------------- roles and assets
    def _roles(self, intent: str, mentions: list[Mention], parts, unknown: list[str], description: str):
        remarks: list[str] = []
        objects: list[Mention] = []
        roles: list[str] = []
        direct = "instrument" if intent in ("open", "close", "press") else "item"
        by_prep = {None: direct, "near": "distractor", "source": "source", "over": "target", "of": direct,
                   "dest": "target" if intent == "position" else "destination"}
        if direct == "instrument":
            by_prep.update(source=direct, over=direct, dest=direct)
        for m in mentions:
            role = by_prep[m.prep]
            if m.is_bench:
                if role == "destination" and intent in ("place", "insert"):
                    raise DraftError("the object already stands on the bench; name where it should go, "
                                     "or where it comes from ('from the balance')")
                continue
            objects.append(m)
            roles.append(role)
        if intent in ("open", "close") and "item" in roles:
            roles = ["instrument" if r == "item" else r for r in roles]
        if unknown:
            hints = []
            for phrase in unknown:
                closest = self.vocab.closest(phrase)
                hint = f"closest assets: {', '.join(closest)}" if closest else "no asset resembles it"
                hints.append(f"unknown object or word {phrase!r} ({hint})")
            raise DraftError(hints + ["see `pipette assets list`, or describe a new asset with `pipette assets new`"])
        needed = {"pick": "item", "place": "item", "insert": "item", "transfer": "item", "position": "item",
                  "open": "instrument", "close": "instrument", "press": "instrument"}[intent]
        if needed not in roles:
            raise DraftError(f"found no object to {intent} in {description!r}; name one from the asset library")
        for role in set(roles):
            if role != "distractor" and roles.count(role) > 1:
                names = [m.phrase for m, r in zip(objects, roles, strict=True) if r == role]
                raise DraftError(f"one task handles one {role} at a time; the description names {len(names)}: {', '.join(names)}")
        self._resolve_assets(objects, roles, remarks)
        specs = [DraftObjectSpec(asset=m.asset, role=r, part=m.part, mention=(m.phrase if not m.sizes else f"{' '.join(m.sizes)} {m.phrase}"))  # type: ignore[arg-type]
                 for m, r in zip(objects, roles, strict=True)]
        return specs, remarks

    def _candidates(self, m: Mention) -> list[str]:
        members = self.vocab.members(m.kind)
        kind = self.vocab.kinds[m.kind]
        for tag in m.sizes:
            keep = [a for a in members if tag in self.vocab.assets[a].size_tags]
            if not keep:
                same_class = sorted({t for a in members for t in self.vocab.assets[a].size_tags if size_class(t) == size_class(tag)})
                if not same_class and size_class(tag) in ("ml", "mm", "ul"):
                    continue  # sizes the kind does not vary by (a "250 mL" pipette stand) carry no choice
                sizes = ", ".join(same_class) if same_class else "no sizes"
                raise DraftError(
                    f"no {tag} {kind.name} in the asset library ({kind.name} sizes: {sizes}); pick one of those, "
                    f"or make it with `pipette assets new \"a {tag} {kind.name}\"`"
                )
            members = keep
        variants = ("nocap", "open", "skirted", "quartz", "large", "small", "carousel", "linear", "deep")
        wanted = {w for w in m.modifiers}
        scored = []
        for a in members:
            info = self.vocab.assets[a]
            id_words = set(a.split("_"))
            score = len(wanted & (info.words | id_words))
            score -= sum(1 for v in variants if v in id_words and v not in wanted)  # plain variants first
            score += 0.5 if a == kind.default else 0.0
            scored.append((-score, a))
        return [a for _, a in sorted(scored)]

    def _resolve_assets(self, mentions: list[Mention], roles: list[str], remarks: list[str]) -> None:
        options = {id(m): self._candidates(m) for m in mentions}
        item = next((m for m, r in zip(mentions, roles, strict=True) if r == "item"), None)
        holder = next((m for m, r in zip(mentions, roles, strict=True) if r == "destination"), None) or \
            next((m for m, r in zip(mentions, roles, strict=True) if r == "source"), None)
        if item is not None and holder is not None:
            pairs = [(i, h) for i in options[id(item)] for h in options[id(holder)]]
            fitting = [(i, h) for i, h in pairs if _fits(self.vocab, i, h) is not False]
            if fitting:
                best = min(fitting, key=lambda p: (options[id(item)].index(p[0]), -_affinity(self.vocab, *p),
                                                   options[id(holder)].index(p[1]), _slack(self.vocab, *p)))
                options[id(item)] = [best[0], *[a for a in options[id(item)] if a != best[0]]]
                options[id(holder)] = [best[1], *[a for a in options[id(holder)] if a != best[1]]]
        for m in mentions:
            choice = options[id(m)]
            m.asset = choice[0]
            equal = [a for a in choice[1:4]]
            if len(choice) > 1 and not m.sizes:
                remarks.append(f"'{m.phrase}' could be {', '.join([choice[0], *equal])}; chose {choice[0]}")


def _hole(vocab: Vocabulary, holder: str) -> float | None:
    sem = vocab.assets[holder].semantics
    if "hole" in sem:
        return float(sem["hole"])
    return None


def _diameter(vocab: Vocabulary, item: str) -> float | None:
    sem = vocab.assets[item].semantics
    for key in ("outer_diameter", "base_diameter", "diameter"):
        if key in sem:
            return float(sem[key])
    return None


def _fits(vocab: Vocabulary, item: str, holder: str) -> bool | None:
    """Whether ``item`` fits the holes of ``holder`` (None when the holder has no holes)."""
    hole, diameter = _hole(vocab, holder), _diameter(vocab, item)
    if hole is None or diameter is None:
        return None
    return diameter + 0.0002 <= hole


def _affinity(vocab: Vocabulary, item: str, holder: str) -> int:
    """Shared size tags and id words: a 15 mL conical tube belongs in the 15 mL conical tube rack."""
    a, b = vocab.assets[item], vocab.assets[holder]
    return 2 * len(a.size_tags & b.size_tags) + len((set(item.split("_")) & set(holder.split("_"))) - {"tube"})


def _slack(vocab: Vocabulary, item: str, holder: str) -> float:
    hole, diameter = _hole(vocab, holder), _diameter(vocab, item)
    return (hole - diameter) if hole is not None and diameter is not None else 1.0


def instruction_from(description: str) -> str:
    """The description as one clean imperative sentence."""
    text = re.sub(r"\s+", " ", description).strip()
    text = re.sub(r"^(please|robot,?|hey robot,?)\s+", "", text, flags=re.I)
    words = sorted((w for ws in robot_words().values() for w in ws), key=len, reverse=True)
    names = "|".join(re.escape(w) for w in words)
    text = re.sub(rf",?\s*(?:with|using) (?:the )?(?:{names})(?: arm| robot)?\b", "", text, flags=re.I)
    text = re.sub(r"\s*,?\s*please\s*[.!]?$", "", text, flags=re.I)
    text = text.rstrip(" .!")
    return (text[:1].upper() + text[1:] + ".") if text else text


def parse_description(description: str, vocabulary: Vocabulary) -> ParseResult:
    """Parse ``description`` into a draft (see :class:`DescriptionParser`)."""
    if not description.strip():
        raise DraftError("the description is empty; say what the robot should do, e.g. 'Pick up the test tube'")
    return DescriptionParser(vocabulary).parse(description)
