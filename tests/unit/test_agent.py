"""The offline agent: requests as users write them -> the exact command, or what is missing."""

from __future__ import annotations

import json
import shlex

import pytest

from pipette_cli.agent.catalog import AgentError, load_catalog
from pipette_cli.agent.offline import Context, OfflineAgent
from pipette_cli.cli.agent import command_line
from pipette_cli.registry import load_registry

AGENT = OfflineAgent(load_catalog(), load_registry())

# request -> the command line it must become
COMMANDS = {
    "list the tasks": "pipette tasks list",
    "which tasks are there?": "pipette tasks list",
    "show me all tasks as json": "pipette tasks list --json",
    "list the lid tasks": "pipette tasks list --tag hatch_control",
    "what tasks use the piper arm": "pipette tasks list --tag agilex_piper",
    "show the water bath task": "pipette tasks show pipette/OpenWaterBathLid-v1",
    "describe PickUpTestTube": "pipette tasks show pipette/PickUpTestTube-v1",
    "explain the pipette rack task": "pipette tasks show pipette/PlacePipetteInRack-v1",
    "details of the flask on shaker task please": "pipette tasks show pipette/PlaceFlaskOnShaker-v1",
    "validate registry/pick_up_test_tube.yaml": "pipette tasks validate",
    "collect 20 demos of the test tube task": "pipette collect pipette/PickUpTestTube-v1 --out data/PickUpTestTube.h5 --episodes 20",
    "record fifty demonstrations for PlaceTubeOnBalance into runs/balance.h5":
        "pipette collect pipette/PlaceTubeOnBalance-v1 --out runs/balance.h5 --episodes 50",
    "gather 10 episodes of closing the centrifuge lid with 64 px images":
        "pipette collect pipette/CloseCentrifugeLid-v1 --out data/CloseCentrifugeLid.h5 --episodes 10 --image-size 64",
    "collect 30 demos of the petri dish retrieval with 2 workers starting at seed 100":
        "pipette collect pipette/RemovePetriDishFromIncubator-v1 --out data/RemovePetriDishFromIncubator.h5 --episodes 30 --seed 100 --workers 2",
    "I want to teleop 5 demos of opening the water bath lid":
        "pipette collect pipette/OpenWaterBathLid-v1 --out data/OpenWaterBathLid.h5 --source teleop --episodes 5",
    "record demonstrations by hand of pressing the centrifuge button, 3 episodes":
        "pipette collect pipette/OpenCentrifugeLid-v1 --out data/OpenCentrifugeLid.h5 --source teleop --episodes 3",
    "inspect data/PickUpTestTube.h5": "pipette data inspect data/PickUpTestTube.h5",
    "what's in runs/balance.h5? give me json": "pipette data inspect runs/balance.h5 --json",
    "replay episode 3 of data/x.h5": "pipette data replay data/x.h5 --episode 3 --check",
    "verify episode 0 in demos/tube.h5 replays exactly": "pipette data replay demos/tube.h5 --episode 0 --check",
    "delete episode 7 from data/x.h5": "pipette data delete-episode data/x.h5 7",
    "render the spectrophotometer task": "pipette sim render pipette/CloseSpectrophotometerLid-v1",
    "what does the incubator placement task look like with seed 4": "pipette sim render pipette/PlacePetriDishInIncubator-v1 --seed 4",
    "take a picture of the balance removal task and save it to out/balance.png":
        "pipette sim render pipette/RemoveTubeFromBalance-v1 --out out/balance.png",
    "how fast does the test tube task simulate?": "pipette sim step-rate pipette/PickUpTestTube-v1",
    "open the viewer on the shaker task": "pipette sim view pipette/PlaceFlaskOnShaker-v1",
    "how good is the scripted expert on the pipette rack task over 20 episodes":
        "pipette experts check pipette/PlacePipetteInRack-v1 --episodes 20",
    "list assets": "pipette assets list",
    "which instruments are in the asset library": "pipette assets list --category instruments",
    "list the consumable assets": "pipette assets list --category consumables",
    "show asset centrifuge_benchtop": "pipette assets show centrifuge_benchtop",
    "validate the assets": "pipette assets validate",
    "create a task where the robot puts the 15 mL conical tube into the tube rack":
        "pipette new-task 'the robot puts the 15 mL conical tube into the tube rack'",
    "new task: \"Close the lid of the thermal cycler\"": "pipette new-task 'Close the lid of the thermal cycler'",
    "make an asset: 'a 300 mL Erlenmeyer flask'": "pipette assets new 'a 300 mL Erlenmeyer flask'",
    "train SmolVLA on the close centrifuge lid task with the augmented data":
        "pipette train --tasks pipette/CloseCentrifugeLid-v1 --policy smolvla --dataset-version augmented",
    "train act for 2k steps on the test tube task with the raw demos on the gpu":
        "pipette train --tasks pipette/PickUpTestTube-v1 --policy act --dataset-version raw --steps 2000 --device cuda",
    "evaluate the policy at tcp://127.0.0.1:5555 on the water bath task for 50 episodes":
        "pipette eval pipette/OpenWaterBathLid-v1 --endpoint tcp://127.0.0.1:5555 --episodes 50",
}

# request -> (command, missing fields)
MISSING = {
    "collect demos": ("collect", ["task_id", "out"]),
    "record some demonstrations please": ("collect", ["task_id", "out"]),
    "inspect the file": ("data inspect", ["file"]),
    "replay an episode": ("data replay", ["file"]),
    "render a task": ("sim render", ["task_id"]),
    "delete episode 2": ("data delete-episode", ["file"]),
}


@pytest.mark.parametrize("request_text", sorted(COMMANDS), ids=lambda r: r[:50])
def test_request_becomes_the_expected_command(request_text: str) -> None:
    plan = AGENT.plan(request_text)
    assert plan.missing == []
    assert shlex.join(command_line(plan)) == COMMANDS[request_text]


@pytest.mark.parametrize("request_text", sorted(MISSING), ids=lambda r: r[:50])
def test_incomplete_request_lists_the_missing_fields(request_text: str) -> None:
    plan = AGENT.plan(request_text)
    assert (plan.command, plan.missing) == MISSING[request_text]


def test_there_are_at_least_forty_requests() -> None:
    assert len(COMMANDS) + len(MISSING) >= 40


def test_unknown_task_gets_the_closest_registered_ones() -> None:
    with pytest.raises(AgentError, match="unknown task 'PickUpTestTub'; did you mean 'PickUpTestTube'"):
        AGENT.plan("collect 5 demos of PickUpTestTub")


def test_ambiguous_task_lists_the_candidates() -> None:
    with pytest.raises(AgentError, match="several tasks: .*CloseCentrifugeLid.*OpenCentrifugeLid"):
        AGENT.plan("collect 5 demos of the centrifuge lid task")


def test_commands_the_cli_does_not_define_are_refused() -> None:
    with pytest.raises(AgentError, match="no command 'pipette shell' in this version"):
        load_catalog().get("shell")
    with pytest.raises(AgentError, match="cannot tell what to run"):
        AGENT.plan("rm -rf /")


def test_catalog_refuses_parameters_the_command_does_not_have() -> None:
    with pytest.raises(AgentError, match="has no parameter 'shell'"):
        load_catalog().argv("tasks list", {"shell": "rm -rf /"})


def test_context_carries_the_task_and_file_between_requests() -> None:
    context = Context()
    first = AGENT.plan("collect 10 demos of the test tube task", context)
    assert first.params["out"] == "data/PickUpTestTube.h5"
    again = AGENT.plan("now render it with seed 3", context)
    assert shlex.join(command_line(again)) == "pipette sim render pipette/PickUpTestTube-v1 --seed 3"
    inspect = AGENT.plan("inspect the file", context)
    assert shlex.join(command_line(inspect)) == "pipette data inspect data/PickUpTestTube.h5"


def test_cli_json_returns_missing_fields(run_cli) -> None:
    result = run_cli("agent", "collect demos", "--json")
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout) == {"command": "collect", "params": {}, "missing": ["task_id", "out"], "notes": []}


def test_cli_runs_the_command_after_yes(run_cli) -> None:
    result = run_cli("agent", "list the lid tasks as json", "--yes")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.splitlines()[0] == "pipette tasks list --tag hatch_control --json"


def test_cli_refuses_without_a_terminal_when_values_are_missing(run_cli) -> None:
    result = run_cli("agent", "render a task")
    assert result.exit_code == 1 and "needs task_id" in result.stderr


def test_llm_agent_output_is_checked_against_the_cli_and_re_asked() -> None:
    """An OpenAI-compatible backend (httpx MockTransport) first names a command the CLI lacks,
    then a valid one; the agent re-asks with the error and accepts only the second."""
    import httpx

    from pipette_cli.agent.llm import LLMAgent

    answers = [
        {"command": "shell", "params": {"cmd": "rm -rf /"}, "missing": [], "notes": []},
        {"command": "collect", "params": {"task_id": "pipette/PickUpTestTube-v1", "episodes": 5}, "missing": [], "notes": []},
    ]
    seen: list[dict] = []

    def reply(request: httpx.Request) -> httpx.Response:
        body = json.loads(request.content)
        seen.append(body)
        content = json.dumps(answers[len(seen) - 1])
        return httpx.Response(200, json={"choices": [{"message": {"role": "assistant", "content": content}}]})

    agent = LLMAgent("openai", load_catalog(), load_registry(), base_url="http://llm.test/v1", model="m",
                     transport=httpx.MockTransport(reply))
    plan = agent.plan("collect five demos of the test tube task")
    assert plan.command == "collect" and plan.missing == ["out"]
    assert len(seen) == 2 and "no command 'pipette shell'" in json.dumps(seen[1]["messages"])
    assert seen[0]["response_format"]["type"] == "json_schema"


def test_interactive_session_keeps_context() -> None:
    """`pipette agent --interactive` in a real process: the second request says "it"."""
    import os
    import subprocess
    import sys

    lines = "collect 10 demos of the test tube task\nn\nnow render it with seed 3\nn\nquit\n"
    result = subprocess.run(
        [sys.executable, "-m", "pipette_cli.cli.main", "agent", "--interactive"],
        input=lines, capture_output=True, text=True, timeout=120, env={**os.environ},
    )
    assert result.returncode == 0, result.stderr
    out = [line.replace("agent>", "").strip() for line in result.stdout.splitlines()]  # prompts share the lines
    assert "pipette collect pipette/PickUpTestTube-v1 --out data/PickUpTestTube.h5 --episodes 10" in out
    assert "pipette sim render pipette/PickUpTestTube-v1 --seed 3" in out
