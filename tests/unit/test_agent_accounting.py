"""Every word of a request accounted for (issue 33): a plan lists the words it does not use,
whoever wrote it, and such a plan never runs under --yes; robots by any registered name."""

from __future__ import annotations

import json

import httpx
import pytest

from pipette_cli.agent.llm import LLMAgent
from pipette_cli.agent.offline import OfflineAgent
from pipette_cli.agent.vocabulary import robot_words
from pipette_cli.cli.main import load_catalog
from pipette_cli.llm import forget_formats
from pipette_cli.registry import load_registry

CATALOG = load_catalog()
REGISTRY = load_registry()
AGENT = OfflineAgent(CATALOG, REGISTRY)


@pytest.mark.parametrize(
    ("request_text", "unused"),
    [
        ("collect 20 demos of the zorbly test tube task", ["zorbly"]),  # a made-up modifier
        ("collect 10 demos of closing the centrifuge lid twice as fast", ["twice", "fast"]),
        ("train act on the test tube task without the wrist camera", ["without", "wrist", "camera"]),
        ("collect 10 demos of the test tube task with distractors on the bench", ["distractors"]),
        ("render the test tube task in ultraviolet", ["ultraviolet"]),
    ],
)
def test_a_word_the_plan_does_not_use_is_listed(request_text: str, unused: list[str]) -> None:
    assert AGENT.plan(request_text).unused == unused


@pytest.mark.parametrize(
    "request_text",
    [
        "Could you please record 5 demos of the test tube task? Thanks",
        "first collect 6 demos of the centrifuge closing task at 48px, then convert them",
        "make 3 augmented copies? no - just augment data/flask.h5 for the shaker task",
        "train ACT on PickUpTestTube and OpenCentrifugeLid using the cpu",
    ],
)
def test_words_that_ask_for_nothing_or_are_taken_back_are_not_listed(request_text: str) -> None:
    assert AGENT.plan(request_text).unused == []


ROBOT_NAMES = ["UR5e", "ur5", "UR5 arm", "ur5e robot", "Universal Robots arm", "ur5e_robotiq"]


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_robots_by_any_registered_name_reach_every_step(name: str) -> None:
    plan = AGENT.plan(f"record 10 demos of closing the centrifuge lid on the {name} and augment them")
    assert [s.args.get("robot") for s in plan.steps] == ["ur5e_robotiq", "ur5e_robotiq"]
    assert plan.unused == []


def test_every_registered_robot_name_is_understood() -> None:
    for robot, names in robot_words().items():
        for name in names:
            plan = AGENT.plan(f"render the test tube task with the {name}")
            assert plan.steps[0].args.get("robot") == robot and plan.unused == [], name


def test_an_llm_plan_is_accounted_for_like_the_parser_s() -> None:
    reply = {"steps": [{"command": "collect", "args": {"task_id": "PickUpTestTube", "episodes": 5}}]}

    def answer(request: httpx.Request) -> httpx.Response:
        content = json.dumps(reply)
        return httpx.Response(200, json={"choices": [{"message": {"role": "assistant", "content": content}}]})

    forget_formats()
    agent = LLMAgent(
        "openai", CATALOG, REGISTRY, base_url="http://llm.test/v1", model="m", transport=httpx.MockTransport(answer)
    )
    plan = agent.plan("record five demos of the test tube task on the piper")
    assert plan.unused == ["piper"]  # the model dropped the robot: said, not run


def test_cli_never_runs_a_plan_with_words_it_did_not_understand(run_cli, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    request = "record 2 demos of the test tube task twice as fast"
    refused = run_cli("agent", request, "--yes")
    assert refused.exit_code == 1 and list(tmp_path.iterdir()) == []
    assert "not run: the request's 'twice', 'fast' are not understood" in " ".join(refused.stderr.split())
    data = json.loads(run_cli("agent", request, "--json", "--yes").stdout)
    assert data["not_understood"] == ["twice", "fast"] and list(tmp_path.iterdir()) == []
    shown = run_cli("agent", request, "--dry-run")
    assert "not understood: 'twice', 'fast'" in " ".join(shown.stderr.split())
