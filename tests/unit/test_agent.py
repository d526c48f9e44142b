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
    "validate registry/pick_up_test_tube.yaml": "pipette tasks validate registry/pick_up_test_tube.yaml",
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
    # every task: train takes `all`; dataset-version words are never a task
    "train act on the augmented data for all tasks":
        "pipette train --tasks all --policy act --dataset-version augmented",
    "train smolvla on every task with the raw demos":
        "pipette train --tasks all --policy smolvla --dataset-version raw",
    "train pi0 on all benchmark tasks for 5k steps": "pipette train --tasks all --policy pi0 --steps 5000",
    "check the scripted expert on every task": "pipette experts check",
    # paths fill path options and are not read as words (no `train` intent, no `act` policy, no task)
    "serve the policy in ckpt/pretrained_model": "pipette serve --policy ckpt/pretrained_model",
    "serve outputs/train/act/x/checkpoints/last/pretrained_model":
        "pipette serve --policy outputs/train/act/x/checkpoints/last/pretrained_model",
    "serve outputs/train/act/x/checkpoints/last/pretrained_model on tcp://0.0.0.0:6000":
        "pipette serve --policy outputs/train/act/x/checkpoints/last/pretrained_model --bind tcp://0.0.0.0:6000",
    "evaluate outputs/train/act/pipette_PickUpTestTube-v1_raw/checkpoints/last/pretrained_model on the water bath task":
        "pipette eval pipette/OpenWaterBathLid-v1 --policy "
        "outputs/train/act/pipette_PickUpTestTube-v1_raw/checkpoints/last/pretrained_model",
    "evaluate the policy in ckpt/smolvla on the test tube task and save the results to evals/smolvla":
        "pipette eval pipette/PickUpTestTube-v1 --policy ckpt/smolvla --out evals/smolvla",
    "evaluate tcp://127.0.0.1:5555 on the test tube task with results in evals/act":  # endpoint given: not --policy
        "pipette eval pipette/PickUpTestTube-v1 --endpoint tcp://127.0.0.1:5555 --out evals/act",
    "evaluate the smolvla policy at tcp://127.0.0.1:5555 on the test tube task":
        "pipette eval pipette/PickUpTestTube-v1 --endpoint tcp://127.0.0.1:5555 --policy-type smolvla",
    "train act on the test tube task fine-tuning from checkpoint ckpt/act_base":
        "pipette train --tasks pipette/PickUpTestTube-v1 --policy act --pretrained-path ckpt/act_base",
    "augment data/raw.h5 into data/aug.h5 for the test tube task":
        "pipette augment pipette/PickUpTestTube-v1 --input data/raw.h5 --output data/aug.h5",
    "collect 5 demos of pipette/PickUpTestTube-v1":  # a task id holds a `/` but is no path
        "pipette collect pipette/PickUpTestTube-v1 --out data/PickUpTestTube.h5 --episodes 5",
    "validate the assets in assets/tools/a.usda and assets/tools/b.usda":
        "pipette assets validate assets/tools/a.usda assets/tools/b.usda",
    "show asset assets/tools/a.usda": "pipette assets show assets/tools/a.usda",
    # asset categories (tools, equipment, consumables, instruments) are assets, not tasks
    "list the instruments": "pipette assets list --category instruments",
    "show the consumables": "pipette assets list --category consumables",
    "which tools are there": "pipette assets list --category tools",
    # `eval report` is reached through `eval`'s first argument; "from" names its input, not --out
    "make a results table from evals/raw": "pipette eval report evals/raw",
    "make a results table from evals/raw and save it to tables/act": "pipette eval report evals/raw --out tables/act",
}

# request -> (command, missing fields)
MISSING = {
    "collect demos": ("collect", ["task_id", "out"]),
    "record some demonstrations please": ("collect", ["task_id", "out"]),
    "inspect the file": ("data inspect", ["file"]),
    "replay an episode": ("data replay", ["file"]),
    "render a task": ("sim render", ["task_id"]),
    "delete episode 2": ("data delete-episode", ["file"]),
    "make a results table": ("eval report", ["folders"]),
    "train act on the augmented data": ("train", ["tasks"]),
    # eval needs --endpoint or --policy: one missing choice, never a command that cannot run
    "evaluate the policy for 10 episodes": ("eval", ["task_id", "endpoint|policy"]),
    "evaluate the policy on the test tube task": ("eval", ["endpoint|policy"]),
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


def test_all_tasks_for_a_command_that_runs_one_is_refused() -> None:
    with pytest.raises(AgentError, match="'pipette eval' runs one task at a time"):
        AGENT.plan("evaluate the policy at tcp://127.0.0.1:5555 on all tasks")


def test_catalog_refuses_eval_without_endpoint_or_policy() -> None:
    with pytest.raises(AgentError, match="'pipette eval' needs endpoint or policy"):
        load_catalog().argv("eval", {"task_id": "pipette/PickUpTestTube-v1", "episodes": 10})
    # a suite stands in for the task: `pipette eval --suite ID` needs no task
    assert load_catalog().missing("eval", {"suite_id": "pipette/PaperBenchmark-v1", "policy": "ckpt"}) == []
    assert load_catalog().missing("eval", {"policy": "ckpt"}) == ["task_id"]


def test_a_path_that_fits_no_option_is_refused_not_dropped() -> None:
    with pytest.raises(AgentError, match="cannot tell what 'ckpt/x' is for in 'pipette train' .*--pretrained-path"):
        AGENT.plan("train act on the test tube task with ckpt/x")
    with pytest.raises(AgentError, match="'pipette tasks list' takes no file or folder, but the request names 'x/y'"):
        AGENT.plan("list the tasks in x/y")


def test_names_on_disk_are_paths_plain_words_are_not(tmp_path, monkeypatch) -> None:
    """A bare name that exists counts as a path when it does not read as a word; `data` stays a
    word although a data/ folder exists."""
    (tmp_path / "data").mkdir()
    (tmp_path / "pretrained_model").mkdir()
    monkeypatch.chdir(tmp_path)
    assert shlex.join(command_line(AGENT.plan("serve pretrained_model"))) == "pipette serve --policy pretrained_model"
    assert shlex.join(command_line(AGENT.plan("evaluate pretrained_model on the test tube task"))) == (
        "pipette eval pipette/PickUpTestTube-v1 --policy pretrained_model")
    assert shlex.join(command_line(AGENT.plan("train act on the augmented data for all tasks"))) == (
        "pipette train --tasks all --policy act --dataset-version augmented")
    assert AGENT.plan("serve the policy in pretrained-model").missing == ["policy"]  # not on disk: a word


def test_cli_json_lists_the_missing_choice(run_cli) -> None:
    result = run_cli("agent", "evaluate the policy for 10 episodes", "--json")
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout) == {"command": "eval", "params": {"episodes": 10},
                                         "missing": ["task_id", "endpoint|policy"], "notes": []}


def test_cli_refuses_eval_without_a_policy_when_it_cannot_ask(run_cli) -> None:
    result = run_cli("agent", "evaluate the policy on the test tube task for 10 episodes", "--yes")
    assert result.exit_code == 1
    assert "'pipette eval' needs endpoint or policy; add them to the request" in result.stderr


def test_interactive_session_asks_which_policy_source_and_its_value() -> None:
    """The missing task is asked for, then which of --endpoint/--policy (a wrong answer is asked
    again), then its value; the command is built from the answers."""
    import os
    import subprocess
    import sys

    lines = "evaluate the policy for 10 episodes\nPickUpTestTube\nserver\npolicy\nckpt/act\nn\nquit\n"
    result = subprocess.run(
        [sys.executable, "-m", "pipette_cli.cli.main", "agent", "--interactive"],
        input=lines, capture_output=True, text=True, timeout=120, env={**os.environ},
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.count("needs one of endpoint, policy; which") == 2  # "server" is asked again
    assert "pipette eval PickUpTestTube --policy ckpt/act --episodes 10" in result.stdout


def test_llm_agent_accepts_train_on_all_tasks() -> None:
    import httpx

    from pipette_cli.agent.llm import LLMAgent

    answer = {"command": "train", "params": {"tasks": "all", "policy": "act"}, "missing": [], "notes": []}
    calls: list[int] = []

    def reply(request: httpx.Request) -> httpx.Response:
        calls.append(1)
        message = {"role": "assistant", "content": json.dumps(answer)}
        return httpx.Response(200, json={"choices": [{"message": message}]})

    agent = LLMAgent("openai", load_catalog(), load_registry(), base_url="http://llm.test/v1", model="m",
                     transport=httpx.MockTransport(reply))
    plan = agent.plan("train act on every task")
    assert shlex.join(command_line(plan)) == "pipette train --tasks all --policy act" and len(calls) == 1
