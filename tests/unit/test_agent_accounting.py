"""Every word of a request accounted for (issue 33): a plan lists the words it does not use,
whoever wrote it, and such a plan never runs under --yes; robots by any registered name."""

from __future__ import annotations

import json
import os

import httpx
import pytest

from pipette_cli.agent.llm import LLMAgent
from pipette_cli.agent.offline import OfflineAgent
from pipette_cli.cli.main import load_catalog
from pipette_cli.llm import forget_formats
from pipette_cli.registry import load_registry
from pipette_cli.specs.robot import robot_words

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


def test_data_questions_count_tags_assets_and_instruments_alike() -> None:
    from pipette_cli.agent.answers import answer

    found = answer("answer tasks", AGENT.plan("how many tasks use the centrifuge?").steps[0].args, REGISTRY)
    tasks = set(found.data["tasks"])
    tagged = {t for t in REGISTRY.ids() if "centrifuge" in REGISTRY.get(t).tags}
    with_asset = {t for t in REGISTRY.ids() if any("centrifuge" in o.asset for o in REGISTRY.get(t).scene.objects)}
    assert tagged and with_asset - tagged and tasks == tagged | with_asset  # the microcentrifuge is a centrifuge


def test_the_last_score_is_the_newest_evaluation_anywhere_under_the_folder(tmp_path, monkeypatch) -> None:
    from pipette_cli.agent.answers import answer

    monkeypatch.chdir(tmp_path)
    for folder, successes, stamp in (("evals/old", 1, 1), ("demo_run/eval", 3, 2)):  # `pipette demo` writes the second
        path = tmp_path / folder
        path.mkdir(parents=True)
        logs = [{"task": "pipette/PickUpTestTube-v1", "success": i < successes, "seed": i} for i in range(4)]
        for i, log in enumerate(logs):
            (path / f"episode_{i:04d}.json").write_text(json.dumps(log))
        summary = {"task": logs[0]["task"], "episodes": 4, "successes": successes, "success_rate": successes / 4}
        (path / "summary.json").write_text(json.dumps(summary))
        for p in path.iterdir():
            os.utime(p, (stamp, stamp))
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "summary.json").write_text('{"not": "an evaluation"}')  # another tool's: skipped
    last = answer("answer score", AGENT.plan("what did the last eval score").steps[0].args)
    assert last.data["last"]["folder"] == "demo_run/eval" and last.data["last"]["successes"] == 3


@pytest.mark.parametrize(
    "request_text",
    [
        "compare raw vs augmented ACT on PickUpTestTube",
        "does augmentation help on the test tube task?",
        "is the augmentation worth it for the test tube task",
        "train act with and without augmented data on PickUpTestTube, 1500 steps each",
        "what does augmentation buy on the test tube task? use 1500 training steps",
    ],
)
def test_a_comparison_becomes_the_whole_experiment(request_text: str) -> None:
    plan = AGENT.plan(request_text)
    assert [s.command for s in plan.steps] == ["train", "train", "eval", "eval", "eval report"]
    assert [s.args.get("dataset_version", "raw") for s in plan.steps[:4]] == ["raw", "augmented"] * 2
    raw, augmented = plan.steps[2], plan.steps[3]
    assert raw.args["policy"].from_step == 1 and augmented.args["policy"].from_step == 2  # each its own policy
    assert raw.args["out"] != augmented.args["out"] and raw.args.get("seed") == augmented.args.get("seed")
    assert [r.from_step for r in plan.steps[4].args["folders"]] == [3, 4]
    assert plan.unused == [] and plan.runnable
    steps = {s.args.get("steps") for s in plan.steps[:2]}
    assert steps == ({1500} if "1500" in request_text else {None})  # the same budget for both, eval untouched
    assert all("episodes" not in s.args for s in plan.steps[2:4]) or "episodes" in request_text


def test_suites_by_name_and_both_outputs_of_a_chain() -> None:
    assert AGENT.plan("evaluate ckpt/a on the paper benchmark suite").steps[0].args["suite_id"] == (
        "pipette/PaperBenchmark-v1"
    )
    assert AGENT.plan("evaluate ckpt/a on the paraphrased paper suite").steps[0].args["suite_id"] == (
        "pipette/PaperBenchmarkParaphrased-v1"
    )
    plan = AGENT.plan("collect 4 demos of the test tube task, augment them, then convert both")
    converts = [s for s in plan.steps if s.command == "convert"]
    assert [c.args["inputs"][0].from_step for c in converts] == [1, 2]
    assert [c.args.get("dataset_version", "raw") for c in converts] == ["raw", "augmented"]


def test_one_backend_registry_for_every_language_front_end(run_cli) -> None:
    from pipette_cli.authoring.backends import make_backend
    from pipette_cli.llm import SERVER_KINDS, backend_names

    assert backend_names() == ["offline", *SERVER_KINDS.names()] and {"openai", "ollama"} <= set(SERVER_KINDS.names())
    for command in (["agent", "collect 2 demos of the test tube task"], ["new-task", "Pick up the test tube"]):
        refused = run_cli(*command, "--backend", "gemini-web", "--dry-run")
        assert refused.exit_code == 1 and "unknown backend 'gemini-web'; use offline, ollama, openai" in refused.stderr
    assert make_backend("offline").name == "offline" and make_backend("ollama", model="m").name == "ollama"


def test_a_question_about_a_robot_or_object_no_task_has_answers_none_not_all() -> None:
    from pipette_cli.agent.answers import answer

    for request, word in (("which tasks can the ur5e do", "ur5e"), ("which tasks use the piper arm", "piper")):
        plan = AGENT.plan(request)
        found = answer("answer tasks", plan.steps[0].args, REGISTRY)
        robot = {"ur5e": "ur5e_robotiq", "piper": "agilex_piper"}[word]
        on_it = sorted(t for t in REGISTRY.ids() if REGISTRY.get(t).embodiment.robot == robot)
        assert plan.unused == [] and found.data["tasks"] == on_it  # [] for the UR5e: none, not every task
