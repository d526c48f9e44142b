"""One step of a description ("put the 15 mL tube in the rack") read against the vocabulary:
its verb, the objects it mentions with their sizes, words and prepositions, the parts it names
("the lid of the centrifuge"), and the words nothing explains.

A word that is both a verb and a noun ("stand", "rack", "slide") is a verb at the start of the
step and a noun after an article. Object mentions are the vocabulary's alias phrases, longest
first; a pronoun ("it", "them") is a mention the parser resolves from the earlier steps.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from pipette_cli.language.assets import Vocabulary, size_class
from pipette_cli.language.mentions import name_at
from pipette_cli.language.phrases import Token, first_match, match

MEASURES = ("ml", "ul", "mm")
"""Size classes that measure rather than name (a lone "6 cm" is a distance, not a 60 mm dish)."""
PART_LINKS = ("of", "on", "in", "inside", "at")
"""Words between a part and its owner: "the lid of the centrifuge", "the button on the microfuge"."""
MAX_COUNT = 6
"""Objects of one kind a count before a noun may ask for ("put two microtubes in the rack"); a larger
number ("96 tubes") is listed as not understood."""


@dataclass
class Mention:
    """An object (or the bench, or a pronoun) named in a step."""

    start: int
    end: int  # exclusive
    kind: str  # a vocabulary kind; "bench" or "pronoun" otherwise
    phrase: str
    sizes: list[str] = field(default_factory=list)
    modifiers: list[str] = field(default_factory=list)
    window_start: int = 0
    prep: str | None = None  # near | source | over | dest | of | None (the direct object)
    prep_phrase: str | None = None
    part: str | None = None
    count: int = 1
    """How many objects of its kind it names ("two microtubes": 2; up to :data:`MAX_COUNT`)."""

    @property
    def is_bench(self) -> bool:
        return self.kind == "bench"

    @property
    def is_pronoun(self) -> bool:
        return self.kind == "pronoun"

    def words(self) -> str:
        return " ".join([*self.sizes, *self.modifiers, self.phrase]).strip()


@dataclass
class Part:
    """A part word ("lid", "top shelf", "button") and the mention it belongs to, if said."""

    start: int
    end: int
    name: str
    phrase: str
    owner: Mention | None = None


@dataclass
class Clause:
    """What one step says."""

    tokens: list[Token]
    action: str | None = None
    verb: str | None = None
    implied_target: str | None = None
    unsupported: list[tuple[str, str]] = field(default_factory=list)  # (group, phrase)
    mentions: list[Mention] = field(default_factory=list)
    parts: list[Part] = field(default_factory=list)
    unknown: list[str] = field(default_factory=list)

    @property
    def text(self) -> str:
        return " ".join(t.text for t in self.tokens)

    def objects(self) -> list[Mention]:
        return [m for m in self.mentions if not m.is_bench]

    def with_prep(self, *preps: str | None) -> list[Mention]:
        return [m for m in self.mentions if m.prep in preps]


PARTICLES = ("open", "shut", "up", "out", "off", "on", "down", "back", "over")
"""Words of a two-word verb that may follow its object ("swing the lid open", "take the tube out",
"switch it on")."""


def gerund(phrase: str) -> str:
    """A verb phrase with its first word in -ing form: lift -> lifting, put -> putting, place -> placing."""
    head, _, rest = phrase.partition(" ")
    if head.endswith("e") and not head.endswith(("ee", "ye", "oe")) and len(head) > 2:
        head = head[:-1] + "ing"
    elif re.fullmatch(r"[^aeiou]*[aeiou][^aeiouwxy]", head):  # one short syllable: drop -> dropping
        head = head + head[-1] + "ing"
    else:
        head += "ing"
    return f"{head} {rest}".strip()


class ClauseReader:
    """Reads steps against one vocabulary (tables built once)."""

    def __init__(self, vocab: Vocabulary) -> None:
        self.vocab = vocab
        words = vocab.words
        self.aliases = vocab.aliases()
        self.bench = sorted(words.bench, key=lambda p: -len(p.split()))
        verbs = {(p, a) for a, ps in words.actions.items() for p in ps}
        verbs |= {(gerund(p), a) for p, a in verbs}  # "by lifting it", "start by opening the lid"
        self.verbs = sorted(verbs, key=lambda pa: (-len(pa[0].split()), pa[0]))
        self.separable: dict[str, list[tuple[str, str, str]]] = {}
        """A verb's first word -> (particle, phrase, action) of its two-word forms whose particle may follow the object."""
        for phrase, action in self.verbs:
            verb, _, tail = phrase.partition(" ")
            if tail in PARTICLES:
                self.separable.setdefault(verb, []).append((tail, phrase, action))
        self.implied = dict(words.implied_targets)
        self.fillers = set(words.fillers)
        self.unsupported_verbs = {p: group for group, u in words.unsupported.items() for p in u.verbs}
        self.part_words = {p: name for name, ps in words.parts.items() for p in ps}
        self.preps = words.preposition_roles()
        self.prep_words = {w for p, _ in self.preps for w in p.split()}
        self.articles = set(words.articles)
        self.fillers = set(words.fillers)
        self.pronouns = sorted(words.pronouns, key=lambda p: -len(p.split()))
        self.runs = sorted(words.runs, key=lambda p: -len(p.split()))
        self.buttons = {p: action for action, ps in words.buttons.items() for p in ps}
        self.buttons |= self._coloured(vocab)
        """A button's name -> the action its press is ("start button" -> run, "green button" -> run)."""
        self.button_names = sorted(self.buttons, key=lambda p: -len(p.split()))
        self.modifiers = words.modifiers
        self.counts = {w: int(v) for w, v in words.numbers.items() if float(v).is_integer()} | {
            **{str(n): n for n in range(MAX_COUNT + 1)},
            "both": 2,
        }
        """A count before a noun, written either way ("two", "2"; "both microtubes")."""
        self.said: list[str] = []
        """The kinds of the objects the clauses read so far name (one reader reads one description)."""

    def _coloured(self, vocab: Vocabulary) -> dict[str, str]:
        """ "green button" -> run where every description that colours a button green calls it a
        start button ("red lid-release button" -> press); a colour used two ways names none."""
        colours = "|".join(map(re.escape, vocab.words.colours)) or "(?!)"
        found: dict[str, set[str]] = {}
        for info in vocab.assets.values():
            for m in re.finditer(rf"\b({colours}) ((?:[\w-]+ )?)button\b", info.description.lower()):
                action = self.buttons.get(f"{m[2]}button", "press")
                found.setdefault(f"{m[1]} button", set()).add(action)
        return {name: actions.pop() for name, actions in found.items() if len(actions) == 1}

    # ------------------------------------------------------------------ verbs
    def verb_at(self, tokens: list[Token], i: int) -> tuple[str, str, int] | None:
        """``(kind, phrase, length)`` of a verb starting at ``i``: kind is an action, ``implied`` or
        ``unsupported``. A word after an article or a size is a noun ("the stand")."""
        if i > 0 and (tokens[i - 1].text in self.articles or tokens[i - 1].kind == "size"):
            return None
        best: tuple[str, str, int] | None = None
        for phrase, action in self.verbs:
            n = match(tokens, i, phrase)
            if n and (best is None or n > best[2]):
                best = (action, phrase, n)
        for table, kind in ((self.implied, "implied"), (self.unsupported_verbs, "unsupported")):
            found = first_match(tokens, i, list(table))
            if found and (
                best is None or found[1] > best[2] or (kind == "unsupported" and found[1] == best[2] and i == 0)
            ):
                best = (kind, found[0], found[1])
        return best

    def is_verb(self, tokens: list[Token], i: int) -> bool:
        """Whether a verb starts at ``i`` (used to split steps at "and" / ",")."""
        found = self.verb_at(tokens, i)
        if found is None:
            return self._particle(tokens, i) is not None  # "..., and switch it on"
        # "and rack" after a noun list is a noun; a verb phrase is followed by an object or a pronoun
        return found[0] != "place" or i + found[2] >= len(tokens) or tokens[i + found[2]].text not in ("and", ",")

    # ------------------------------------------------------------------ reading
    def read(self, tokens: list[Token]) -> Clause:
        clause = Clause(tokens)
        verbs = self._verbs(clause)
        self._mentions(clause, verbs)
        self._sizes_and_modifiers(clause, verbs)
        self._lone_sizes(clause)
        self._parts(clause)
        self._prepositions(clause, verbs)
        self._unknown(clause)
        self.said += [m.kind for m in clause.mentions if not m.is_bench and not m.is_pronoun]
        return clause

    def _verbs(self, clause: Clause) -> set[int]:
        tokens = clause.tokens
        at: set[int] = set()
        i = 0
        while i < len(tokens):
            found = self.verb_at(tokens, i) if tokens[i].kind == "word" else None
            particle = self._particle(tokens, i) if clause.action is None and (found is None or found[2] == 1) else None
            if particle is not None:  # "swing the lid open": swing open
                found, tokens[particle[1]].used = particle[0], True
                at.add(particle[1])
            # a verb-noun word ("stand", "rack") is a verb only where no action was found yet; after
            # one, a word that starts an object's name ("the sparkly pipette tip box") names it
            if found is not None and clause.action is not None and name_at(tokens, i, self.aliases) is not None:
                found = None
            if found is not None and clause.action is not None and found[0] == clause.action:
                for k in range(i, i + found[2]):  # the same action said twice: "hand me the flask by lifting it"
                    tokens[k].used = True
                at.update(range(i, i + found[2]))
                i += found[2]
                continue
            if found is not None and (clause.action is None or found[0] == "unsupported"):
                kind, phrase, n = found
                if kind == "unsupported":
                    clause.unsupported.append((self.unsupported_verbs[phrase], phrase))
                    if clause.action is None:
                        clause.verb = phrase
                elif clause.action is None and not clause.unsupported:
                    if kind == "implied":
                        clause.action, clause.implied_target = "place", self.implied[phrase]
                    else:
                        clause.action = kind
                    clause.verb = phrase
                at.update(range(i, i + n))
                for k in range(i, i + n):
                    tokens[k].used = True
                i += n
                continue
            i += 1
        return at

    def _particle(self, tokens: list[Token], i: int) -> tuple[tuple[str, str, int], int] | None:
        """A two-word verb whose particle ends the clause after its object ("swing the lid open",
        "push the drawer shut"): the verb as found at ``i`` (one word long) and where its particle is."""
        if tokens[i].kind != "word" or (i > 0 and tokens[i - 1].text in self.articles):
            return None
        for tail, phrase, action in self.separable.get(tokens[i].text, []):
            for j in range(i + 2, min(i + 8, len(tokens))):
                if tokens[j].kind == "punct" or tokens[j].text in ("and", "then"):
                    break
                rest = tokens[j + 1 :]
                end = next((k for k, t in enumerate(rest) if t.kind == "punct" or t.text in ("and", "then")), len(rest))
                last = all(t.text in self.fillers for t in rest[:end])  # "take it off again afterwards"
                if tokens[j].text == tail and last:  # "out of the rack" is where from, not a particle
                    return (action, phrase, 1), j
        return None

    def _mentions(self, clause: Clause, verbs: set[int]) -> None:
        tokens = clause.tokens
        i = 0
        while i < len(tokens):
            if i in verbs or tokens[i].kind != "word":
                i += 1
                continue
            name = name_at(tokens, i, self.aliases, stop=verbs)  # "pipette tip box": one tip box
            head = name.phrase if name else ""
            alias = None
            if name is not None:
                shown = " ".join(t.text for t in tokens[i : name.end]) if name.compound else name.phrase
                alias = (shown, name.end - i)
            bench = first_match(tokens, i, self.bench)
            pronoun = first_match(tokens, i, self.pronouns)
            part = first_match(tokens, i, list(self.part_words))
            found: tuple[str, str, int] | None = None
            alias_kind = self.vocab.alias_to_kind[head] if alias else None
            owned = part is not None and (
                self._part_has_owner(clause, i, part[1])
                or self._owner_said(clause, self.part_words[part[0]], alias_kind)
            )
            if alias and alias_kind and (not part or alias[1] > part[1] or not owned):
                found = (alias_kind, alias[0], alias[1])
            if bench and (found is None or bench[1] > found[2]):
                found = ("bench", bench[0], bench[1])
            counts = pronoun is not None and pronoun[0] in self.counts  # "one microtube": a count, not "the one"
            if counts and pronoun is not None and name_at(tokens, i + pronoun[1], self.aliases, stop=verbs) is None:
                counts = False
            if found is None and pronoun and not part and not counts:
                found = ("pronoun", pronoun[0], pronoun[1])
            button = first_match(tokens, i, self.button_names) if found is None else None
            if button is not None and clause.action in ("press", *self.buttons.values()):
                clause.action = self.buttons[button[0]]  # "press the start button": a run, of the
                for k in range(i, i + button[1]):  # instrument named with it or the one named before
                    tokens[k].used = True
                i += button[1]
                continue
            run = first_match(tokens, i, self.runs) if found is None and clause.action == "run" else None
            if run is not None:  # "start the spin": the instrument whose run it is
                found = ("pronoun", run[0], run[1])
            if found is None:
                i += part[1] if part is not None and owned else 1  # "the top shelf": never a "shelf" of its own
                continue
            kind, phrase, n = found
            clause.mentions.append(Mention(i, i + n, kind, phrase, window_start=i))
            for k in range(i, i + n):
                tokens[k].used = True
            i += n

    def _owner_said(self, clause: Clause, part: str, kind: str | None) -> bool:
        """Whether an object named before, in this clause or an earlier one of the description, has
        the part ``part`` ("open the incubator, then put the dish on the top shelf": its shelf, not
        a reagent shelf of ``kind``)."""
        said = [*self.said, *(m.kind for m in clause.mentions if not m.is_bench and not m.is_pronoun)]
        return any(k != kind and self.vocab.has_part(k, part) for k in said)

    def _part_has_owner(self, clause: Clause, i: int, n: int) -> bool:
        """A part word directly after a mention ("incubator shelf") or before "of the X"."""
        tokens = clause.tokens
        before = clause.mentions[-1] if clause.mentions and clause.mentions[-1].end == i else None
        if before is not None and not before.is_bench and not before.is_pronoun:
            return True
        k = i + n
        return (
            k < len(tokens)
            and tokens[k].text in PART_LINKS
            and any(first_match(clause.tokens, j, self.aliases) for j in range(k + 1, min(k + 4, len(tokens))))
        )

    def _sizes_and_modifiers(self, clause: Clause, verbs: set[int]) -> None:
        tokens = clause.tokens
        for index, m in enumerate(clause.mentions):
            floor = clause.mentions[index - 1].end if index else 0
            k = m.start - 1
            while (
                k >= floor
                and tokens[k].kind != "punct"
                and k not in verbs
                and tokens[k].text not in self.articles
                and (tokens[k].kind == "size" or tokens[k].text not in self.prep_words)
            ):
                if tokens[k].kind == "size":
                    m.sizes.append(tokens[k].text)
                    tokens[k].used = True
                elif not tokens[k].used and (tokens[k].text.isdigit() or tokens[k].text in self.counts):
                    if 1 <= self.counts.get(tokens[k].text, 0) <= MAX_COUNT:  # "two microtubes"; "96 tubes" listed
                        m.count, tokens[k].used = self.counts[tokens[k].text], True
                elif not tokens[k].used:
                    two = f"{tokens[k].text} {tokens[k + 1].text}" if k + 1 < m.start else ""
                    modifier = self.modifiers.get(two) or self.modifiers.get(tokens[k].text)
                    m.modifiers.append(modifier or tokens[k].text)
                    if modifier or self.vocab.describes(tokens[k].text, m.kind):
                        tokens[k].used = True
                k -= 1
            m.window_start = k + 1
            m.sizes.reverse()
            m.modifiers.reverse()
            after = tokens[m.end] if m.end < len(tokens) else None  # "the tube without its cap" (-> nocap)
            if after is not None and not after.used and after.text in set(self.modifiers.values()):
                m.modifiers.append(after.text)
                after.used = True

    def _lone_sizes(self, clause: Clause) -> None:
        """A size no mention takes that only one kind has names an object of that kind ("the P200"
        is a pipette, "the T75" a flask; "the P10", a size no pipette has, a pipette too, so the
        refusal lists the pipettes' sizes); a size several kinds share ("15 mL") or a measure
        ("6 cm") stays a size."""
        for i, token in enumerate(clause.tokens):
            if token.kind != "size" or token.used or size_class(token.text) in MEASURES:
                continue
            kinds = {k for info in self.vocab.assets.values() if token.text in info.size_tags for k in info.kinds[:1]}
            if not kinds:  # a size none has ("the P10"): the one kind sized that way, to say which sizes it has
                unit = size_class(token.text)
                kinds = {
                    k
                    for info in self.vocab.assets.values()
                    if any(size_class(t) == unit for t in info.size_tags)
                    for k in info.kinds[:1]
                }
            if len(kinds) == 1:
                kind = kinds.pop()
                clause.mentions.append(Mention(i, i + 1, kind, kind, sizes=[token.text], window_start=i))
                token.used = True
        clause.mentions.sort(key=lambda m: m.start)

    def _parts(self, clause: Clause) -> None:
        tokens = clause.tokens
        i = 0
        while i < len(tokens):
            part = first_match(tokens, i, list(self.part_words)) if not tokens[i].used else None
            if part is None:
                i += 1
                continue
            phrase, n = part
            name = self.part_words[phrase]
            prev = next((m for m in reversed(clause.mentions) if m.end <= i), None)
            nxt = next((m for m in clause.mentions if m.start >= i + n), None)
            owner = None
            if prev is not None and not prev.is_bench and all(t.text in self.articles for t in tokens[prev.end : i]):
                owner = prev  # "the centrifuge lid", "the incubator's door"
            elif nxt is not None and not nxt.is_bench:
                between = [t.text for t in tokens[i + n : nxt.window_start]]
                if between and between[0] in PART_LINKS and all(w in self.articles for w in between[1:]):
                    owner = nxt  # "the lid of the centrifuge", "the button on the centrifuge"
                    for k in range(i + n, nxt.window_start):
                        tokens[k].used = True
            clause.parts.append(Part(i, i + n, name, phrase, owner))
            if owner is not None and owner.part is None:
                owner.part = name
            for k in range(i, i + n):
                tokens[k].used = True
            i += n

    def _prepositions(self, clause: Clause, verbs: set[int]) -> None:
        tokens = clause.tokens
        anchors = sorted(
            {max(verbs) + 1 if verbs else 0, *(m.end for m in clause.mentions), *(p.end for p in clause.parts)}
        )
        for m in clause.mentions:
            owned = [p for p in clause.parts if p.owner is m and p.start < m.start]
            start = owned[0].start if owned else m.window_start
            floor = max([a for a in anchors if a <= start] or [0])
            k = floor
            while k < start:
                for phrase, role in self.preps:
                    n = match(tokens, k, phrase)
                    if n and k + n <= start:
                        m.prep, m.prep_phrase = role, phrase
                        for j in range(k, k + n):
                            tokens[j].used = True
                        k += n - 1
                        break
                k += 1

    def _unknown(self, clause: Clause) -> None:
        current: list[str] = []
        for token in [*clause.tokens, Token(".", "punct")]:
            unknown = not token.used and (  # a size no object takes ("6 cm" nowhere) is not understood either
                token.kind == "size"
                or (
                    token.kind == "word"
                    and token.text not in self.fillers
                    and token.text not in self.articles
                    and token.text not in self.prep_words
                )
            )
            if unknown:
                current.append(token.text)
            elif current:
                clause.unknown.append(" ".join(current))
                current = []
