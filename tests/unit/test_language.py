"""The parts both language front-ends share (pipette_cli/language/): the clause splitter, the
name resolver and the robot names, on their own."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipette_cli.errors import SpecError
from pipette_cli.language.assets import VOCABULARY_FILE, VocabularySpec, load_vocabulary, vocabulary_files
from pipette_cli.language.clauses import Separators, pieces, split_clauses
from pipette_cli.language.lexicon import robot_mentions
from pipette_cli.language.mentions import find_mentions, names_in
from pipette_cli.language.phrases import find_phrase
from pipette_cli.language.understanding import not_understood_line, refused_under_yes
from pipette_cli.specs.yaml_io import read_spec

SEPARATORS = Separators(
    strong=("then", "and then", "after that", "next"),
    weak=(",", "and", ":"),
    openers=("first", "to begin with"),
    keep=("next to",),
)


def test_pieces_keep_the_strongest_separator_and_drop_openers() -> None:
    text = "First pick up the tube, then put it next to the rack and close the lid. Then press start"
    got = [(p.text.strip(), p.after) for p in pieces(text, SEPARATORS)]
    assert got == [
        ("pick up the tube", "start"),
        ("put it next to the rack", "strong"),  # "next to" is a place, not the sequence word "next"
        ("close the lid", "weak"),
        ("press start", "strong"),  # ". Then": the stronger of a sentence end and a sequence word
    ]


def test_the_grammar_decides_which_weak_cut_starts_a_clause() -> None:
    text = "pick up the tube and the vial, then close the lid: press start"
    default = [c.text for c in split_clauses(text, SEPARATORS)]
    assert default == ["pick up the tube and the vial", "close the lid: press start"]
    verbs = {"pick", "close", "press"}
    by_verb = [c.text for c in split_clauses(text, SEPARATORS, lambda p, _: p.text.split()[0] in verbs)]
    assert by_verb == ["pick up the tube and the vial", "close the lid", "press start"]


def test_names_are_found_whole_before_their_parts_and_in_the_plural() -> None:
    vocab = load_vocabulary()
    found = [(name.phrase, kind) for name, kind in vocab.names_in("put the pipette tip box and two beakers away")]
    assert found[0][0] == "tip box" and found[0][1] == vocab.alias_to_kind["tip box"]  # not a pipette tip
    assert ("beaker", "beaker") in found
    plain = names_in("the pipette tip box", ["pipette tip", "tip box"])
    assert [(n.phrase, n.compound, n.start, n.end) for n in plain] == [("tip box", True, 1, 4)]


def test_robot_names_come_from_the_robot_registry() -> None:
    text, robots = robot_mentions("close the lid with the ur5 arm")
    assert robots == ["ur5e_robotiq"] and "ur5" not in text and "close the lid" in text
    assert robot_mentions("close the lid")[1] == []


def test_one_wording_for_what_was_not_understood() -> None:
    assert not_understood_line([]) == ""
    assert not_understood_line(["zorbly"], "draft") == "not understood: 'zorbly' (the draft above does not use it)"
    assert not_understood_line(["a", "b"], None) == "not understood: 'a', 'b'"
    assert refused_under_yes(["a", "b"], "write").startswith("not written: the request's 'a', 'b' are not understood")


def test_optional_words_may_open_a_phrase() -> None:
    phrase = "(only|just)? (the)? top (view|camera)"
    assert [find_phrase([phrase], t).group(0) for t in ("gif of the top view", "just the top camera, please")] == [
        "the top view",
        "just the top camera",
    ]
    assert find_phrase([phrase], "the top shelf") is None


def test_an_arrow_before_a_path_reads_as_to() -> None:
    found = find_mentions("augment (data/a.h5 -> data/b.h5) and x.h5=>y.h5")
    assert [(m.path, m.before.split()[-1]) for m in found.paths[1::2]] == [("data/b.h5", "to"), ("y.h5", "to")]


def test_purposes_name_kinds_of_the_vocabulary(tmp_path: Path) -> None:
    vocab = load_vocabulary()
    assert set(vocab.words.purposes) <= set(vocab.kinds) and "cold" in vocab.words.purposes["ice bucket"]
    text = vocabulary_files()[0].read_text().replace("  ice bucket: [cold,", "  ice box thing: [cold,", 1)
    broken = tmp_path / VOCABULARY_FILE
    broken.write_text(text)
    with pytest.raises(SpecError, match="purposes names no kind: ice box thing"):
        read_spec(broken, VocabularySpec)
