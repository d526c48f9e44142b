"""The offline backend over descriptions written as users write them (tests/fixtures/authoring).

Every good description must give the expected intent, assets and robot, render to registry
YAML that validates, and build (scene compiles, nothing interpenetrates, targets in reach).
Every bad one must fail with a message that says what is wrong, and nothing is produced.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from ruamel.yaml import YAML

from pipette_cli.authoring.backends import make_backend
from pipette_cli.authoring.draft import DraftError
from pipette_cli.authoring.workflow import draft_task
from pipette_cli.errors import PipetteError
from pipette_cli.registry import load_registry
from pipette_cli.specs.yaml_io import parse_yaml

CASES = YAML(typ="safe").load((Path(__file__).parents[1] / "fixtures" / "authoring" / "descriptions.yaml").read_text())
GOOD = CASES["good"]
BAD = CASES["bad"]


def test_the_fixture_covers_every_family_with_enough_descriptions() -> None:
    assert len(GOOD) >= 30
    assert {c["intent"] for c in GOOD} == {"pick", "place", "insert", "open", "close", "press", "transfer", "position"}


@pytest.fixture(scope="module")
def registry():
    return load_registry()


@pytest.mark.parametrize("case", GOOD, ids=[c["text"][:60] for c in GOOD])
def test_offline_draft_matches_and_builds(case, registry) -> None:
    # a namespace of its own: the registry already holds drafts of some of these descriptions
    drafted = draft_task(case["text"], make_backend("offline"), registry=registry, namespace="testgen")
    draft = drafted.draft
    assert draft.intent == case["intent"]
    assert {o.role: o.asset for o in draft.objects} == case["objects"]
    assert (draft.robot or None) == case.get("robot")
    assert draft.thresholds.model_dump(exclude_none=True) == case.get("thresholds", {})
    spec = drafted.spec
    assert spec.embodiment.robot == (case.get("robot") or "franka_panda")
    assert {o.asset for o in spec.scene.objects} >= set(case["objects"].values()) - {None}
    assert case["intent"] in spec.tags and "generated" in spec.tags
    assert "VERIFY" in drafted.yaml_text
    # the written YAML is what validates: comments included, parsed back to the same spec
    assert parse_yaml(drafted.yaml_text)["id"] == spec.id


@pytest.mark.parametrize("case", BAD, ids=[c["text"][:60] or "<empty>" for c in BAD])
def test_bad_descriptions_fail_with_a_reason(case) -> None:
    with pytest.raises(PipetteError) as info:
        draft_task(case["text"], make_backend("offline"))
    message = " ".join(getattr(info.value, "problems", None) or [str(info.value)])
    assert case["error"] in message
    assert isinstance(info.value, DraftError)


def test_same_description_gives_the_same_yaml() -> None:
    text = "Put the 96-well plate on the orbital shaker"
    first = draft_task(text, make_backend("offline")).yaml_text
    assert draft_task(text, make_backend("offline")).yaml_text == first
