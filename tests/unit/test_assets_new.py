"""``pipette assets new``'s word accounting: every word of a description is used or listed."""

from __future__ import annotations

import pytest

from pipette_cli.authoring.assets_new import AssetDraftSpec, parse_asset, unused_words


@pytest.mark.parametrize(
    ("text", "unused"),
    [
        ("a 300 mL Erlenmeyer flask", []),
        ("please make me a new 2L beaker", []),  # a glued unit, litres for a mL size, request words
        ("a 12 cm petri dish", []),  # centimetres for a mm size
        ("a 16 x 150 mm test tube", []),
        ("a tall 500 mL media bottle", ["tall"]),
        ("a 300 mL Erlenmeyer flask, 250 mm wide", ["250", "wide"]),  # a number the draft does not hold
        ("a 2,000 mL beaker with a spout", ["spout"]),
    ],
)
def test_the_offline_parser_uses_every_word_of_a_description_or_lists_it(text, unused) -> None:
    assert unused_words(text, parse_asset(text)) == unused


def test_the_made_assets_own_description_explains_its_words() -> None:
    spec = AssetDraftSpec(generator="media_bottle", volume_ml=500)
    text = "a 500 mL glass media bottle with a blue cap"
    assert unused_words(text, spec) == ["glass", "blue", "cap"]
    assert unused_words(text, spec, "500 mL borosilicate glass media bottle with GL45 blue screw cap") == []


def test_an_llm_answer_of_another_size_leaves_the_said_size_unexplained() -> None:
    said = "a 300 mL beaker"
    assert unused_words(said, AssetDraftSpec(generator="beaker", volume_ml=250)) == ["300", "ml"]
