"""The offline backend over the development set (tests/fixtures/authoring/descriptions.yaml).

Every sentence must give the expected plan (actions, assets, robot) and a task whose YAML
validates and builds (scene compiles, nothing interpenetrates, targets in reach), or the expected
one-line refusal; nothing else (no traceback, no raw validation dump). Whether the generated
experts solve the tasks is measured by benchmarks/bench_new_task.py (it runs the physics).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from ruamel.yaml import YAML

from pipette_cli.authoring.backends import make_backend
from pipette_cli.authoring.plan import PlanError
from pipette_cli.authoring.workflow import draft_task, plan_summary
from pipette_cli.registry import load_registry
from pipette_cli.specs.yaml_io import parse_yaml

CASES = YAML(typ="safe").load((Path(__file__).parents[1] / "fixtures" / "authoring" / "descriptions.yaml").read_text())[
    "cases"
]
TASKS = [c for c in CASES if "steps" in c]
REFUSALS = [c for c in CASES if "refuse" in c]
KNOWN_GAPS = {
    # the incubator's door, closed at the start, stands where the Panda's hand is in its home pose
    # wherever its shelves are in reach (an open door at the start leaves room: those tasks draft)
    "Open the incubator and put the petri dish on the shelf",
    "First open the incubator door and then put the petri dish on the top shelf",
}


def test_the_development_set_is_large_and_varied() -> None:
    assert len(CASES) >= 60 and len(REFUSALS) >= 15
    actions = {s.split()[0] for c in TASKS for s in c["steps"]}
    assert actions == {"pick", "place", "remove", "open", "close", "press", "position"}
    assert sum(len(c["steps"]) > 1 for c in TASKS) >= 8  # multi-step descriptions


@pytest.fixture(scope="module")
def registry():
    return load_registry()


@pytest.mark.parametrize("case", TASKS, ids=[c["text"][:60] for c in TASKS])
def test_offline_plan_matches_and_builds(case, registry) -> None:
    if case["text"] in KNOWN_GAPS:
        with pytest.raises(PlanError, match="impossible layout"):
            draft_task(case["text"], make_backend("offline"), registry=registry, namespace="testgen")
        return
    # a namespace of its own: the registry already holds drafts of some of these descriptions
    drafted = draft_task(case["text"], make_backend("offline"), registry=registry, namespace="testgen")
    assert plan_summary(drafted.composed.checked) == case["steps"]
    spec = drafted.spec
    assert spec.embodiment.robot == case.get("robot", "franka_panda")
    assert len(spec.expert) >= len(case["steps"])  # every step has skill steps
    if len(case["steps"]) > 1:
        assert spec.success.type == "sequence" and len(spec.success.of) == len(case["steps"])
    assert "VERIFY" in drafted.yaml_text and "generated" in spec.tags
    assert parse_yaml(drafted.yaml_text)["id"] == spec.id  # the written YAML is what validates


@pytest.mark.parametrize("case", REFUSALS, ids=[c["text"][:60] or "<empty>" for c in REFUSALS])
def test_refusals_are_one_clear_line(case) -> None:
    with pytest.raises(PlanError) as info:
        draft_task(case["text"], make_backend("offline"))
    problems = info.value.problems
    assert len(problems) == 1 and "\n" not in problems[0]
    assert case["refuse"] in problems[0]
    assert "validation error" not in problems[0] and "pydantic" not in problems[0]


def test_same_description_gives_the_same_yaml() -> None:
    text = "Open the microcentrifuge, put the 1.5 mL tube in, then close the lid"
    first = draft_task(text, make_backend("offline")).yaml_text
    assert draft_task(text, make_backend("offline")).yaml_text == first
