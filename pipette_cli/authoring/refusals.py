"""What a description asks that no task can be: what the simulator cannot do (liquids, caps,
running instruments without a start button), words that name nothing known, and words before a
known object that describe none of its kind. Each is refused in one line with the reason; no word
of a description is dropped in silence.
"""

from __future__ import annotations

import re

from pipette_cli.authoring.clause import Clause
from pipette_cli.authoring.plan import PlanError
from pipette_cli.authoring.vocabulary import Vocabulary

ACTION_WORDS = "pick up, place, put, insert, remove, take out, open, close, press, hold over, start"


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


def refuse_unknown(clauses: list[Clause], vocab: Vocabulary) -> list[str]:
    """``unknown object 'X'; nearest: ...`` for words that name nothing; ``not understood`` for a
    word before a known object that describes none of its kind ("the zorbly flask" is no flask of
    the library: choosing one anyway would drop the word). Words that describe a member choose it."""
    remarks: list[str] = []
    for clause in clauses:
        for phrase in clause.unknown:
            owner = next((m for m in clause.mentions if set(phrase.split()) <= set(m.modifiers)), None)
            if owner is not None:
                strange = [w for w in phrase.split() if not vocab.describes(w, owner.kind)]
                if strange:
                    raise PlanError(
                        f"not understood: '{' '.join(strange)}' in '{owner.words()}': no {owner.kind} of the asset "
                        f"library is described by it; leave it out or name the object as `pipette assets list` does"
                    )
                continue
            if clause.action is None and clause.tokens and phrase.split()[0] == clause.tokens[0].text:
                raise PlanError(f"unknown action '{phrase}'; actions: {ACTION_WORDS}")
            nearest = vocab.nearest(phrase)
            hint = ", ".join(nearest) if nearest else "nothing similar (see `pipette assets list`)"
            raise PlanError(f"unknown object '{phrase}'; nearest: {hint}")
    return remarks
