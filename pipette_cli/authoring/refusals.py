"""What a description asks that no task can be, and the words no plan uses: what the simulator
cannot do (liquids, caps, running instruments without a start button) and words where an object or
an action belongs that name nothing are refused in one line with the reason; any other word nothing
explains is listed with the draft as not understood. No word of a description is dropped in silence.
"""

from __future__ import annotations

import re

from pipette_cli.authoring.clause import Clause
from pipette_cli.language.assets import Vocabulary
from pipette_cli.taskgen.plan import PlanError

ACTION_WORDS = "pick up, place, put, insert, remove, take out, open, close, press, hold over, start, tare"


def refuse_unsupported(clauses: list[Clause], vocab: Vocabulary) -> None:
    """Refuse (finally) what the simulator cannot do, with the vocabulary's reason."""
    groups = vocab.words.unsupported
    for clause in clauses:
        for group, phrase in clause.unsupported:
            if clause.action is None or clause.verb == phrase:
                raise PlanError(f"cannot '{phrase}': {groups[group].reason}", final=True)
        leftover = " ".join(clause.unknown)  # "the buffer bottle" names a bottle: moving it is fine
        for spec in groups.values():
            for word in spec.words:
                if re.search(rf"\b{re.escape(word)}\b", leftover):
                    raise PlanError(f"'{word}': {spec.reason}", final=True)


def refuse_unknown(clauses: list[Clause], vocab: Vocabulary, *, refuse: bool = True) -> list[str]:
    """Refuse words that stand where an object or an action belongs but name nothing (after an
    article, a preposition or a number, "the -80 freezer": ``unknown object 'X'; nearest: ...``;
    first in a step without a verb: ``unknown action``). Return the other words nothing explains,
    listed as not understood with the draft: a word before a known object that describes none of
    its kind ("the zorbly flask": choosing a flask anyway without saying so would drop the word), or
    a word outside any object ("very zorbishly"). Words that describe a member choose it. With
    ``refuse`` False every such word is listed (an LLM may still plan without them)."""
    listed: list[str] = []
    prepositions = {w for p, _ in vocab.words.preposition_roles() for w in p.split()}
    for clause in clauses:
        texts = [t.text for t in clause.tokens]
        for phrase in clause.unknown:
            owner = next((m for m in clause.mentions if set(phrase.split()) <= set(m.modifiers)), None)
            if owner is not None:
                listed += [" ".join(w for w in phrase.split() if not vocab.describes(w, owner.kind))]
                continue
            if not refuse:
                listed.append(phrase)
                continue
            if clause.action is None and clause.tokens and phrase.split()[0] == clause.tokens[0].text:
                raise PlanError(f"unknown action '{phrase}'; actions: {ACTION_WORDS}")
            at = _position(texts, phrase)
            before = texts[at - 1] if at > 0 else ""
            if at <= 0 or before in vocab.words.articles or before in prepositions or before[:1].isdigit():
                nearest = vocab.nearest(phrase)
                hint = ", ".join(nearest) if nearest else "nothing similar (see `pipette assets list`)"
                raise PlanError(f"unknown object '{phrase}'; nearest: {hint}")
            listed.append(phrase)
    return [w for w in listed if w]


def _position(words: list[str], phrase: str) -> int:
    """Where ``phrase`` starts among ``words`` (-1 if it does not)."""
    parts = phrase.split()
    return next((i for i in range(len(words)) if words[i : i + len(parts)] == parts), -1)
