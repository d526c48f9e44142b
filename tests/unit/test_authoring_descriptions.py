"""The offline backend over the development set (tests/fixtures/authoring/descriptions.yaml).

Every sentence must give the expected plan (actions, assets, robot) and a task whose YAML
validates and builds (scene compiles, nothing interpenetrates, targets in reach), or the expected
one-line refusal; nothing else (no traceback, no raw validation dump). Whether the generated
experts solve the tasks is measured by benchmarks/bench_new_task.py (it runs the physics).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from ruamel.yaml import YAML

from pipette_cli.authoring.backends import make_backend
from pipette_cli.authoring.workflow import draft_task, plan_summary
from pipette_cli.registry import load_registry
from pipette_cli.specs.yaml_io import parse_yaml
from pipette_cli.taskgen.naming import MAX_ID
from pipette_cli.taskgen.plan import PlanError

CASES = YAML(typ="safe").load((Path(__file__).parents[1] / "fixtures" / "authoring" / "descriptions.yaml").read_text())[
    "cases"
]
TASKS = [c for c in CASES if "steps" in c]
REFUSALS = [c for c in CASES if "refuse" in c]


CRITERIA = {
    # the criterion each action may become (lids differ: by hand, by button, lifted off)
    "pick": {"lift_and_hold"},
    "place": {"region_hold"},
    "remove": {"displacement"},
    "position": {"near_target"},
    "open": {"joint_threshold", "displacement"},
    "close": {"joint_threshold", "region_hold"},
    "press": {"mechanism_triggered", "joint_threshold"},
    "run": {"instrument_state"},
    "tare": {"instrument_state"},
}


def test_the_development_set_is_large_and_varied() -> None:
    assert len(CASES) >= 150 and len(REFUSALS) >= 15
    actions = {s.split()[0] for c in TASKS for s in c["steps"]}
    assert actions == set(CRITERIA)
    assert sum(len(c["steps"]) > 1 for c in TASKS) >= 8  # multi-step descriptions
    assert sum("from" in c for c in TASKS) >= 10 and sum("criteria" in c for c in TASKS) >= 10
    relations = {s.split()[2] for c in TASKS for s in c["steps"] if len(s.split()) == 4}
    assert relations == {"next_to", "left_of", "right_of", "behind", "in_front_of"}


@pytest.fixture(scope="module")
def registry():
    return load_registry()


@pytest.mark.parametrize("case", TASKS, ids=[c["text"][:60] for c in TASKS])
def test_offline_plan_matches_and_builds(case, registry) -> None:
    # a namespace of its own: the registry already holds drafts of some of these descriptions
    drafted = draft_task(case["text"], make_backend("offline"), registry=registry, namespace="testgen")
    assert plan_summary(drafted.composed.checked) == case["steps"]
    assert drafted.not_understood == case.get("not_understood", [])  # listed, never dropped in silence
    spec = drafted.spec
    assert spec.embodiment.robot == case.get("robot", "franka_panda")
    assert len(spec.expert) >= len(case["steps"])  # every step has skill steps
    if len(case["steps"]) > 1:
        assert spec.success.type == "sequence" and len(spec.success.of) == len(case["steps"])
    assert "VERIFY" in drafted.yaml_text and "generated" in spec.tags
    assert parse_yaml(drafted.yaml_text)["id"] == spec.id  # the written YAML is what validates
    _assert_meaning(case, drafted)


def _assert_meaning(case: dict, drafted) -> None:
    """What the task means, beyond its plan: one stage per step with the criterion its action
    becomes, placements that count once let go, a readable id, an instruction per stage, where
    the moved object starts, and no word of the description dropped."""
    spec = drafted.spec
    stages = spec.success.of if len(case["steps"]) > 1 else [spec.success]
    assert len(stages) == len(case["steps"])
    types = [stage.type for stage in stages]
    for line, kind in zip(case["steps"], types, strict=True):
        assert kind in CRITERIA[line.split()[0]], (line, kind)
    assert types == case.get("criteria", types)
    for line, stage in zip(case["steps"], stages, strict=True):
        if line.startswith("place "):
            assert stage.released, line  # a placement counts once the hand has let go
    if len(stages) > 1:
        instructions = [stage.instruction for stage in stages]
        assert all(instructions) and len(set(instructions)) == len(instructions)
    assert spec.instruction
    assert len(f"generated/{spec.id.split('/', 1)[1]}") <= MAX_ID and re.fullmatch(r"[a-z]+/[A-Za-z0-9]+-v1", spec.id)
    if "from" in case:
        checked = drafted.composed.checked
        moved = checked.steps[0].object
        holder = drafted.composed.starts.get(moved)
        assert holder is not None and checked.asset(holder) == case["from"]
    assert not [r for r in drafted.remarks if r.startswith("ignored")]


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
