"""`pipette agent`: the development set, the catalog read from typer, the one validator, the LLM
path through the same validator, answers computed from data, and the CLI around them."""

from __future__ import annotations

import enum
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Annotated

import httpx
import numpy as np
import pytest
import typer

from pipette_cli.agent.answers import answer
from pipette_cli.agent.catalog import AgentError, Unsupported, read_catalog
from pipette_cli.agent.devset import canonical, load_dev_set, run_case, step_lines
from pipette_cli.agent.llm import LLMAgent, plan_schema
from pipette_cli.agent.offline import OfflineAgent
from pipette_cli.agent.plan import Context, PlanSpec, StepRef
from pipette_cli.agent.validate import Validator
from pipette_cli.agent.vocabulary import load_vocabulary
from pipette_cli.cli.main import load_catalog
from pipette_cli.errors import BackendError
from pipette_cli.llm import forget_formats
from pipette_cli.registry import load_registry

DEV_SET = Path(__file__).parents[1] / "fixtures" / "agent" / "dev_set.yaml"
CATALOG = load_catalog()
REGISTRY = load_registry()
AGENT = OfflineAgent(CATALOG, REGISTRY)
CASES = load_dev_set(DEV_SET)


@pytest.mark.parametrize("case", CASES, ids=[c.request[:60] for c in CASES])
def test_dev_set_request_becomes_the_expected_plan(case) -> None:
    result = run_case(AGENT, case, CATALOG)
    assert not result.crashed, result.error
    assert result.right, f"got {result.got} missing={result.missing} unused={result.unused} error={result.error}"


def test_dev_set_is_large_and_covers_every_kind() -> None:
    kinds = {c.kind for c in CASES}
    assert len(CASES) >= 60 and kinds == {"single", "chained", "inspection", "unsupported", "missing", "error"}
    assert sum(c.kind == "chained" for c in CASES) >= 10 and len({c.request for c in CASES}) == len(CASES)


# -- the catalog is the typer app ---------------------------------------------------------------


def test_catalog_lists_every_leaf_command_of_the_cli() -> None:
    from pipette_cli.cli.main import app

    def leaves(command, path=()):
        subs = getattr(command, "commands", None)
        if subs:
            return [leaf for name, sub in subs.items() for leaf in leaves(sub, (*path, name))]
        return [" ".join(path), *(" ".join((*path, n)) for n in getattr(command, "subcommands", {}))]

    cli = set(leaves(typer.main.get_command(app))) - {"agent"}
    assert cli == {n for n in CATALOG.commands if not n.startswith("answer ")}
    collect = CATALOG.get("collect")
    assert (
        collect.params["episodes"].kind,
        collect.params["episodes"].default,
        collect.params["episodes"].minimum,
    ) == ("int", 10, 0)
    assert collect.params["source"].choices == ("scripted", "teleop") and collect.params["out"].writes
    assert CATALOG.get("train").params["policy"].choices == ("act", "smolvla", "pi0")
    assert CATALOG.get("convert").params["video"].off_flag == "--images"
    assert "demos" in collect.params["episodes"].units and "max steps" in collect.params["max_steps"].names
    assert "checkpoint" in CATALOG.get("train").params["pretrained_path"].names  # the words people use for it
    assert CATALOG.get("eval").params["endpoint"].address and CATALOG.get("eval report").params["folders"].multiple


class Robot(str, enum.Enum):
    panda = "panda"
    ur5e = "ur5e"
    piper = "piper"


def test_an_option_added_to_the_cli_is_understood_by_its_own_words() -> None:
    """Other engineers add options (`--robot`, `--suite`) while the agent exists: the catalog is
    read from the app, and the agent fills the new option from its choices and name."""
    app = typer.Typer()

    @app.command("collect")
    def collect(
        task_id: Annotated[str, typer.Argument(help="Task id.")],
        out: Annotated[Path, typer.Option("--out", help="HDF5 file to create.")],
        episodes: Annotated[int, typer.Option("--episodes", min=1, help="Episodes.")] = 10,
        robot: Annotated[Robot, typer.Option("--robot", help="Arm to use.")] = Robot.panda,
        suite_size: Annotated[int, typer.Option("--suite-size", help="Tasks in the suite.")] = 3,
    ) -> None:
        """Record."""

    @app.command("render")
    def render(task_id: Annotated[str, typer.Argument(help="Task id.")]) -> None:
        """Render."""

    catalog = read_catalog((app, ()))
    assert catalog.get("collect").params["robot"].choices == ("panda", "ur5e", "piper")
    plan = OfflineAgent(catalog, REGISTRY).plan("collect 7 demos of the test tube task on the ur5e with suite size 4")
    assert plan.steps[0].args == {
        "task_id": "pipette/PickUpTestTube-v1",
        "episodes": 7,
        "robot": "ur5e",
        "suite_size": 4,
        "out": "data/PickUpTestTube.h5",
    }
    with pytest.raises(AgentError, match="must be one of panda, ur5e, piper, not 'kuka'"):
        Validator(catalog, REGISTRY, load_vocabulary()).check(
            PlanSpec.model_validate(
                {"steps": [{"command": "collect", "args": {"task_id": "PickUpTestTube", "robot": "kuka"}}]}
            )
        )


def test_every_vocabulary_entry_names_a_command_or_option_of_the_cli() -> None:
    vocab = load_vocabulary()
    params = {p for info in CATALOG.commands.values() for p in info.params}
    assert set(vocab.intents) <= set(CATALOG.commands)
    for key in [*vocab.options, *vocab.values, *vocab.carry_to]:
        command, _, param = key.rpartition(".")
        assert param in (CATALOG.get(command).params if command else params), key
    for key in [*vocab.defaults, *vocab.consumes]:
        command, _, param = key.rpartition(".")
        assert param in CATALOG.get(command).params, key
    assert set(vocab.products) <= set(CATALOG.commands) and set(vocab.one_of) <= set(CATALOG.commands)
    assert vocab.bare_number in params


# -- one validator for every plan -----------------------------------------------------------------

VALIDATOR = Validator(CATALOG, REGISTRY, load_vocabulary())


def check(*steps: dict):
    return VALIDATOR.check(PlanSpec.model_validate({"steps": list(steps)}))


def test_validator_types_values_and_resolves_task_names() -> None:
    plan = check({"command": "collect", "args": {"task_id": "PickUpTestTube", "--episodes": "20", "image-size": 64.0}})
    assert plan.steps[0].args == {
        "task_id": "pipette/PickUpTestTube-v1",
        "episodes": 20,
        "image_size": 64,
        "out": "data/PickUpTestTube.h5",
    }
    assert plan.steps[0].product == "data/PickUpTestTube.h5" and plan.runnable


@pytest.mark.parametrize(
    ("step", "message"),
    [
        ({"command": "shell", "args": {}}, "no command 'pipette shell'"),
        ({"command": "collect", "args": {"task_id": "PickUpTestTube", "cmd": "rm -rf /"}}, "has no parameter 'cmd'"),
        ({"command": "collect", "args": {"task_id": "PickUpTestTube", "episodes": "lots"}}, "takes an int, not 'lots'"),
        ({"command": "collect", "args": {"task_id": "PickUpTestTube", "image_size": 4}}, "must be >= 16"),
        ({"command": "collect", "args": {"task_id": "PickUpTestTub"}}, "unknown task 'PickUpTestTub'"),
        ({"command": "train", "args": {"tasks": "all", "policy": "diffusion"}}, "Diffusion Policy is not supported"),
        ({"command": "eval", "args": {"task_id": "all", "endpoint": "tcp://h:1"}}, "runs one task at a time"),
        (
            {"command": "augment", "args": {"task_id": "PickUpTestTube", "input": {"from_step": 1}}},
            "can only use an earlier step's output",
        ),
    ],
    ids=["command", "parameter", "type", "range", "task", "policy", "all", "reference"],
)
def test_validator_refuses_with_one_clear_line(step, message) -> None:
    with pytest.raises(AgentError, match=message):
        check(step)


def test_unsupported_is_final_and_lists_what_is_supported() -> None:
    with pytest.raises(Unsupported) as info:
        check(
            {"command": "eval", "args": {"task_id": "PickUpTestTube", "endpoint": "tcp://h:1", "policy_type": "VQ-BeT"}}
        )
    assert str(info.value) == "VQ-BeT is not supported; supported are ACT, SmolVLA, pi0" and info.value.final


def test_validator_links_outputs_carries_values_and_lists_missing() -> None:
    plan = check(
        {"command": "collect", "args": {"task_id": "OpenWaterBathLid", "image_size": 32}},
        {"command": "augment", "args": {}},
        {"command": "convert", "args": {}},
        {"command": "train", "args": {"policy": "act"}},
        {"command": "eval", "args": {"episodes": 5}},
        {"command": "data stats", "args": {}},
    )
    s = plan.steps
    assert s[1].args["input"] == StepRef(from_step=1) and s[2].args["inputs"] == [StepRef(from_step=2)]
    assert s[2].args["dataset_version"] == "augmented" and s[3].args["dataset_version"] == "augmented"
    assert s[3].product == "outputs/train/act/pipette_OpenWaterBathLid-v1_augmented/checkpoints/last/pretrained_model"
    assert s[4].args["policy"] == StepRef(from_step=4) and s[4].args["image_size"] == 32
    assert (
        s[5].args["root"] == StepRef(from_step=3) and s[2].product == "datasets/pipette_OpenWaterBathLid-v1/augmented"
    )
    assert plan.runnable and plan.resolved_args(s[1])["input"] == "data/OpenWaterBathLid.h5"
    incomplete = check({"command": "augment", "args": {"input": "runs/x.h5"}}, {"command": "serve", "args": {}})
    assert incomplete.missing == {1: ["task_id", "output"], 2: ["policy"]}


def test_context_carries_the_task_and_outputs_between_requests() -> None:
    context = Context()
    first = AGENT.plan("collect 10 demos of the test tube task", context)
    context.remember(first)
    assert context.task == "pipette/PickUpTestTube-v1" and context.products == {"demos": "data/PickUpTestTube.h5"}
    again = AGENT.plan("now render it with seed 3", context)
    assert step_lines(again, CATALOG) == ["sim render pipette/PickUpTestTube-v1 --seed 3"]
    assert step_lines(AGENT.plan("inspect the file", context), CATALOG) == ["data inspect data/PickUpTestTube.h5"]


def test_canonical_form_ignores_defaults_and_option_order() -> None:
    assert canonical("collect T --episodes 10 --out x.h5 --seed 0", CATALOG) == "collect T --out x.h5"
    assert canonical("convert a.h5 --video --images", CATALOG) == "convert a.h5 --images"


# -- the LLM path: same plan model, same validator -----------------------------------------------


def llm_agent(replies: list[dict], seen: list[dict]) -> LLMAgent:
    forget_formats()

    def reply(request: httpx.Request) -> httpx.Response:
        seen.append(json.loads(request.content))
        content = json.dumps(replies[min(len(seen), len(replies)) - 1])
        return httpx.Response(200, json={"choices": [{"message": {"role": "assistant", "content": content}}]})

    return LLMAgent(
        "openai",
        CATALOG,
        REGISTRY,
        base_url="http://llm.test/v1",
        model="m",
        max_attempts=3,
        transport=httpx.MockTransport(reply),
    )


def test_llm_plan_is_validated_and_re_asked_with_the_error() -> None:
    seen: list[dict] = []
    agent = llm_agent(
        [
            {"steps": [{"command": "collect", "args": {"task_id": "PickUpTestTube", "demos": 5}}]},
            {
                "steps": [
                    {"command": "collect", "args": {"task_id": "PickUpTestTube", "episodes": 5}},
                    {"command": "augment", "args": {"input": {"from_step": 1}}},
                ]
            },
        ],
        seen,
    )
    plan = agent.plan("record five demos of the test tube task and augment them")
    assert step_lines(plan, CATALOG) == [
        "collect pipette/PickUpTestTube-v1 --out data/PickUpTestTube.h5 --episodes 5",
        "augment pipette/PickUpTestTube-v1 --input @1 --output data/PickUpTestTube_augmented.h5",
    ]
    assert len(seen) == 2 and "has no parameter 'demos'" in seen[1]["messages"][-1]["content"]
    schema = seen[0]["response_format"]["json_schema"]["schema"]
    shapes = schema["properties"]["steps"]["items"]["anyOf"]
    collect = next(s for s in shapes if s["properties"]["command"]["enum"] == ["collect"])
    assert "pipette/PickUpTestTube-v1" in collect["properties"]["args"]["properties"]["task_id"]["enum"]
    assert collect["properties"]["args"]["additionalProperties"] is False


def test_llm_unsupported_policy_ends_at_once_and_bad_plans_never_pass() -> None:
    seen: list[dict] = []
    with pytest.raises(Unsupported, match="Diffusion Policy is not supported"):
        llm_agent([{"steps": [{"command": "train", "args": {"tasks": "all", "policy": "diffusion"}}]}], seen).plan(
            "train diffusion on everything"
        )
    assert len(seen) == 1
    seen = []
    with pytest.raises(BackendError) as info:
        llm_agent([{"steps": [{"command": "shell", "args": {"cmd": "rm -rf /"}}]}], seen).plan("wipe the disk")
    assert len(seen) == 3 and "no command 'pipette shell'" in " ".join(info.value.problems)


def test_llm_schema_narrows_parameters_of_the_commands_the_request_points_to() -> None:
    schema = plan_schema(CATALOG, {"train"}, REGISTRY.ids())
    shapes = schema["properties"]["steps"]["items"]["anyOf"]
    train = shapes[0]["properties"]["args"]["properties"]
    assert train["policy"]["enum"] == ["act", "smolvla", "pi0"] and "all" in train["tasks"]["enum"]
    assert "train" not in shapes[1]["properties"]["command"]["enum"]


# -- answers from the data --------------------------------------------------------------------------


def record(path: Path, task_id: str, outcomes: list[bool]) -> None:
    """A real episode file written by the project's recorder (synthetic content, no simulation)."""
    from pipette_cli.demos.recorder import DatasetInfo, EpisodeWriter
    from pipette_cli.demos.store import pack, part_path
    from pipette_cli.evaluators.base import Verdict
    from pipette_cli.sim.env import Observation

    info = DatasetInfo(
        task_id=task_id,
        embodiment="franka_panda",
        instruction="x",
        image_height=4,
        image_width=4,
        cameras=("top",),
        physics_hz=600,
        control_hz=30,
        vision_hz=10,
        state_dim=8,
        action_dim=8,
        sim_state_size=3,
    )
    for i, ok in enumerate(outcomes):
        writer = EpisodeWriter(part_path(path, i), info, index=i, seed=i, source="scripted")
        obs = Observation({"top": np.zeros((4, 4, 3), np.uint8)}, np.zeros(8, np.float32), True, 0, 0.0, 0.0, 1, "x")
        writer.add(obs, np.zeros(8), np.zeros(3))
        writer.close(
            Verdict(success=ok, failed=not ok, reason=None if ok else "dropped", metrics={}), np.zeros(8), np.zeros(3)
        )
        writer.commit()
    pack(path)


def test_answers_count_demos_in_hdf5_files(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    record(Path("data/tube.h5"), "pipette/PickUpTestTube-v1", [True, True, False])
    record(Path("data/bath.h5"), "pipette/OpenWaterBathLid-v1", [True])
    one = answer("answer demos", AGENT.plan("how many demos are in data/tube.h5").steps[0].args)
    assert one.text == "data/tube.h5 holds 3 demos of pipette/PickUpTestTube-v1: 2 successful, 1 failed (episode 2)"
    which = answer("answer demos", AGENT.plan("which of the recordings in data/tube.h5 failed?").steps[0].args)
    assert which.data["files"][0]["failed_episodes"] == [2]
    by_task = answer("answer demos", AGENT.plan("how many demos do I have of the water bath task").steps[0].args)
    assert by_task.data["total"] == 1 and by_task.data["files"][0]["file"] == "data/bath.h5"
    assert answer("answer demos", {}).data["total"] == 4


def test_answers_read_the_last_evaluation(tmp_path, monkeypatch) -> None:
    from dataclasses import asdict

    from pipette_cli.evaluation.evaluate import EpisodeLog

    monkeypatch.chdir(tmp_path)
    old, new = Path("evals/old"), Path("evals/PickUpTestTube")
    old.mkdir(parents=True)
    (old / "summary.json").write_text(
        json.dumps(
            {
                "task": "pipette/OpenWaterBathLid-v1",
                "policy_type": "act",
                "episodes": 4,
                "successes": 1,
                "success_rate": 0.25,
                "dataset_version": "raw",
            }
        )
    )
    os.utime(old / "summary.json", (1, 1))
    new.mkdir(parents=True)
    for i, ok in enumerate([True, False, True]):  # an interrupted run: episode files, no summary yet
        log = EpisodeLog(
            task="pipette/PickUpTestTube-v1",
            episode=i,
            seed=i,
            instruction="Pick up the test tube.",
            success=ok,
            failure_reason=None,
            runtime_s=1.0,
            sim_time_s=1.0,
            control_steps=30,
            control_hz=30.0,
            policy_queries=10,
            policy_hz=10.0,
            failed_queries=0,
            safe_hold=False,
            policy_type="smolvla",
            gripper_thresholds={},
        )
        (new / f"episode_{i:04d}.json").write_text(json.dumps(asdict(log)))
    last = answer("answer score", AGENT.plan("what did the last eval score").steps[0].args)
    assert (
        last.text.startswith("evals/PickUpTestTube: pipette/PickUpTestTube-v1 with smolvla")
        and "2/3 = 67 %" in last.text
    )
    water = answer("answer score", AGENT.plan("how did the last evaluation of the water bath task go").steps[0].args)
    assert water.data["last"]["success_rate"] == 0.25
    with pytest.raises(AgentError):
        AGENT.plan("what did the last eval score on the foo task")  # unknown names are not silently ignored


def test_answers_list_tasks_from_the_registry() -> None:
    piper = answer("answer tasks", AGENT.plan("which tasks use the piper arm").steps[0].args)
    assert piper.data["tasks"] == ["pipette/PlaceFlaskOnShaker-v1"]
    lids = answer("answer tasks", AGENT.plan("list every task that has a lid").steps[0].args).data["tasks"]
    assert "pipette/CloseCentrifugeLid-v1" in lids and "pipette/PickUpTestTube-v1" not in lids
    assert answer("answer tasks", {}).data["count"] == len(REGISTRY.ids())


def test_answers_list_the_robots_from_their_specs() -> None:
    plan = AGENT.plan("what robots can I use?")
    assert [s.command for s in plan.steps] == ["answer robots"] and plan.unused == []
    said = answer("answer robots", plan.steps[0].args)
    widths = [max(len(c), *(len(r[i]) for r in said.rows)) for i, c in enumerate(said.columns)]
    assert sum(widths) + 3 * len(widths) + 1 <= 80  # its table, borders and padding included, reads at 80 columns
    found = said.data["robots"]
    by_name = {r["robot"]: r for r in found}
    assert sorted(by_name) == ["agilex_piper", "franka_panda", "ur5e_robotiq"]
    assert by_name["franka_panda"]["gripper_opening_mm"] == 80 and by_name["franka_panda"]["arm_joints"] == 7
    assert by_name["agilex_piper"]["tasks"] == 1  # PlaceFlaskOnShaker names the Piper


# -- the command -------------------------------------------------------------------------------


def test_cli_json_prints_the_plan_and_the_missing_values(run_cli) -> None:
    result = run_cli("agent", "collect demos", "--json")
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["runnable"] is False and data["steps"][0]["missing"] == ["task_id", "out"]
    chained = json.loads(run_cli("agent", "record 3 demos of the test tube task and augment them", "--json").stdout)
    assert chained["steps"][1]["args"]["input"] == {"from_step": 1}
    assert chained["steps"][1]["command_line"].startswith("pipette augment pipette/PickUpTestTube-v1 --input data/")


@pytest.mark.parametrize(
    "case",
    [
        next(c for c in CASES if c.kind == kind)
        for kind in ("single", "chained", "inspection", "unsupported", "missing", "error")
    ],
    ids=lambda c: c.kind,
)
def test_cli_answers_every_kind_of_request_without_a_traceback(run_cli, case, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = run_cli("agent", case.request, "--json")
    assert "Traceback" not in result.stderr
    assert result.exit_code == (1 if case.error else 0), result.stderr
    if case.error:
        assert case.error.lower() in result.stderr.lower().replace("\n", " ")
    else:
        assert len(json.loads(result.stdout)["steps"]) == len(case.plan)


def test_cli_answers_from_the_registry_the_command_was_given(run_cli, fixtures_dir, monkeypatch) -> None:
    from pipette_cli.cli.common import STATE

    monkeypatch.setattr(STATE, "registry_dirs", [])
    result = run_cli(
        "--registry-dir", fixtures_dir / "demos" / "registry", "agent", "how many tasks are there", "--json"
    )
    assert result.exit_code == 0, result.stderr
    extra = len(load_registry([fixtures_dir / "demos" / "registry"]).ids())
    assert json.loads(result.stdout)["steps"][0]["answer"]["count"] == extra > len(REGISTRY.ids())


def test_cli_names_the_missing_values_when_it_cannot_ask(run_cli) -> None:
    result = run_cli("agent", "evaluate the policy on the test tube task", "--yes")
    assert result.exit_code == 1
    assert "step 1 (pipette eval) needs endpoint or policy; add it to the request" in result.stderr


def test_cli_dry_run_shows_the_plan_and_runs_nothing(run_cli, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    request = "record 3 demos of the test tube task and augment them"
    result = run_cli("agent", request, "--dry-run", "--yes")  # --yes does not override it
    assert result.exit_code == 0, result.stderr
    assert "pipette collect" in result.stdout and "pipette augment" in result.stdout  # the plan table
    assert "dry run: 2 steps planned, nothing run" in result.stderr and list(tmp_path.iterdir()) == []
    missing = run_cli("agent", "evaluate the policy on the test tube task", "--dry-run")
    assert missing.exit_code == 0 and "needs endpoint or policy" in " ".join(missing.stdout.split())
    data = json.loads(run_cli("agent", request, "--dry-run", "--json", "--yes").stdout)
    assert data["dry_run"] is True and len(data["steps"]) == 2 and list(tmp_path.iterdir()) == []
    for command in ("agent", "new-task"):  # the same option on both
        assert "--dry-run" in run_cli(command, "--help").stdout


def test_cli_answers_questions_without_running_anything(run_cli) -> None:
    result = run_cli("agent", "which tasks involve the centrifuge?")
    assert result.exit_code == 0 and result.stdout.startswith("9 tasks about centrifuge")  # a microcentrifuge is one


def test_cli_runs_steps_and_stops_at_the_first_failure(run_cli, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    record(Path("data/tube.h5"), "pipette/PickUpTestTube-v1", [True])
    ok = run_cli(
        "agent", "inspect data/tube.h5 then validate registry/none.yaml and then show the water bath task", "--yes"
    )
    assert ok.exit_code == 1
    assert "step 2 (pipette tasks validate registry/none.yaml) failed with exit code 1" in ok.stderr
    assert "steps 3-3 did not run" in ok.stderr and "pipette/PickUpTestTube-v1" in ok.stdout  # step 1 ran
    assert "Lift the lid off" not in ok.stdout  # step 3 (tasks show) did not run


def test_interactive_session_asks_for_missing_values_and_keeps_context(tmp_path) -> None:
    lines = (
        "evaluate the policy for 10 episodes\nPickUpTestTube\nserver\npolicy\nckpt/act\nn\n"
        "collect 4 demos of the water bath task\nn\nnow render it with seed 3\nn\nquit\n"
    )
    result = subprocess.run(
        [sys.executable, "-m", "pipette_cli.cli.main", "agent", "--interactive"],
        input=lines,
        capture_output=True,
        text=True,
        timeout=180,
        env={**os.environ, "COLUMNS": "200"},
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.count("needs one of endpoint, policy; which") == 2  # "server" is asked again
    out = " ".join(result.stdout.split())
    assert "pipette eval pipette/PickUpTestTube-v1 --policy ckpt/act --episodes 10" in out
    assert "pipette sim render pipette/OpenWaterBathLid-v1 --seed 3" in out


def test_a_suite_stands_in_for_the_task_of_eval() -> None:
    catalog = load_catalog()
    assert catalog.missing("eval", {"suite_id": "pipette/PaperBenchmark-v1", "policy": "ckpt"}) == []
    assert catalog.missing("eval", {"policy": "ckpt"}) == ["task_id"]


def test_coordinated_words_each_take_the_noun_after_them() -> None:
    from pipette_cli.agent.vocabulary import distributed

    nouns = load_vocabulary().distributes
    assert distributed("with object and clutter variants", nouns) == "with object variants and clutter variants"
    assert distributed("light, cam and object variants", nouns) == "light variants, cam variants and object variants"
    assert distributed("collect demos and convert them", nouns) == "collect demos and convert them"


def test_compound_number_words_are_read_and_accounted() -> None:
    spelled = load_vocabulary().spelled
    assert spelled["twenty-five"] == spelled["twenty five"] == 25 and spelled["ninety-nine"] == 99
    plan = AGENT.plan("collect twenty-five demos of the water bath task")
    assert plan.steps[0].args["episodes"] == 25 and plan.unused == []


def test_an_indexed_device_keeps_its_index_and_is_no_count() -> None:
    plan = AGENT.plan("evaluate ckpt/a on the tube pick-up task on cuda:0 with 4 workers")
    args = plan.steps[0].args
    assert args["device"] == "cuda:0" and args["workers"] == 4 and "episodes" not in args and plan.unused == []


def test_a_clause_reporting_what_happened_plans_nothing_and_gives_its_file() -> None:
    plan = AGENT.plan("the recording into data/night.h5 crashed; merge its leftover parts")
    assert [s.command for s in plan.steps] == ["data pack"] and plan.steps[0].args["file"] == "data/night.h5"
    assert plan.unused == []
    alone = AGENT.plan("collect 5 demos of the tube pick-up task, it crashed")  # the last clause: nothing follows
    assert [s.command for s in alone.steps] == ["collect"]


def test_resuming_after_a_report_runs_that_step_again_and_takes_no_count_from_the_report() -> None:
    plan = AGENT.plan("the eval of runs/act on the tube pick-up task was stopped after 30 episodes; resume it")
    [step] = plan.steps
    assert step.command == "eval" and step.args.get("policy") == "runs/act" and "episodes" not in step.args
    assert step.args["task_id"] == "pipette/PickUpTestTube-v1"
    assert plan.unused == []  # "after 30 episodes" tells how far it got: the report's count is not the step's
    counted = AGENT.plan("evaluate runs/act on the tube pick-up task for 30 episodes, then resume it")
    assert counted.steps[0].args.get("episodes") == 30  # no report: the count is the step's


def test_what_a_report_tells_after_its_event_is_its_story_and_what_it_asks_stays_accounted() -> None:
    plan = AGENT.plan(
        "ACT training on the augmented spectrophotometer data died at step 9000 of 15000 when the node rebooted. "
        "pick it up from the last checkpoint"
    )
    assert [s.command for s in plan.steps] == ["train"] and plan.steps[0].args["if_exists"] == "continue"
    assert plan.unused == []
    counted = AGENT.plan("the collect of 40 demos of the tube pick-up task was killed after 12; resume it")
    assert counted.unused == ["40"]  # said before the event: a value of the step, which the plan does not take


def test_a_later_step_with_an_optional_task_takes_the_task_before_unless_it_reads_a_step() -> None:
    plan = AGENT.plan(
        "render the ReadPlate protocol with seed 7 into r.png, then check its scripted expert on ten seeds"
    )
    assert [(s.command, s.args.get("task_id") or s.args.get("tasks")) for s in plan.steps] == [
        ("sim render", "protocols/ReadPlate-v1"),
        ("experts check", ["protocols/ReadPlate-v1"]),  # not every task: "its" expert
    ]
    alone = AGENT.plan("check the scripted experts on ten seeds")
    assert not alone.steps[0].args.get("tasks")  # a first step without a task: every task, as the CLI does
    asked = AGENT.plan("record 8 demos of the spectrophotometer lid, then tell me how many succeeded")
    assert "task" not in asked.steps[1].args  # it reads step 1's file, which has its task


def test_where_a_file_goes_is_no_action_of_the_task() -> None:
    with pytest.raises(AgentError, match="could mean several tasks"):  # "into" is no "place": four tube tasks
        AGENT.plan("record 5 demos of the tube task into data/x.h5")
    plan = AGENT.plan("record 5 demos of putting the tube on the balance into data/x.h5")
    assert plan.steps[0].args["task_id"] == "pipette/PlaceTubeOnBalance-v1"


def test_both_outputs_into_one_dataset_is_one_step_reading_both() -> None:
    plan = AGENT.plan(
        "collect 15 demos of the test tube pick-up on the UR5e and another 15 on the Piper, "
        "then convert both into one dataset at datasets/mixed (allow mixed robots)"
    )
    assert [s.command for s in plan.steps] == ["collect", "collect", "convert"]
    convert = plan.steps[2].args
    assert convert["inputs"] == [StepRef(from_step=1), StepRef(from_step=2)] and convert["allow_mixed_robots"]
    assert "allow_mixed" not in convert  # "allow mixed robots" is not also "allow mixed" (tasks)
    assert plan.unused == []  # "another": the command once more
    apart = AGENT.plan(
        "collect 5 demos of the test tube pick-up, then 5 demos of the centrifuge lid opening, then convert both"
    )
    assert [s.command for s in apart.steps] == ["collect", "collect", "convert", "convert"]  # one dataset each


def test_a_folder_is_never_the_file_a_step_reads() -> None:
    plan = AGENT.plan("record 3 demos of the tube pick-up into data/t.h5, then make GIFs of all of them in videos/t/")
    video = plan.steps[1].args
    assert video["file"] == StepRef(from_step=1) and video["out"] == "videos/t/" and video["all_episodes"]


def test_a_clause_after_then_without_a_verb_takes_the_verb_before() -> None:
    plan = AGENT.plan("describe the water bath lid task, then the ReadPlate protocol")
    assert [(s.command, s.args.get("task_id")) for s in plan.steps] == [
        ("tasks show", "pipette/OpenWaterBathLid-v1"),
        ("tasks show", "protocols/ReadPlate-v1"),
    ]


def test_asset_options_take_every_id_written_and_a_plural_kind_whole() -> None:
    plan = AGENT.plan("make a contact sheet of beaker_50ml and beaker_100ml, 2 per row")
    assert plan.steps[0].args["targets"] == ["beaker_50ml", "beaker_100ml"] and plan.steps[0].args["columns"] == 2
    beakers = AGENT.plan("a contact sheet of the beakers")
    assert set(beakers.steps[0].args["targets"]) >= {"beaker_50ml", "beaker_250ml", "beaker_1000ml"}
    assert beakers.unused == []


def test_a_plural_option_name_after_a_number_sets_it_and_a_possessive_is_its_noun() -> None:
    plan = AGENT.plan("train act on PickUpTestTube's raw data with 3 threads")
    assert plan.steps[0].args["threads"] == 3 and plan.unused == []


def test_an_unsupported_policy_is_refused_before_a_path_it_cannot_place() -> None:
    with pytest.raises(Unsupported, match="Octo is not supported"):
        AGENT.plan("fine-tune octo on the shaker task, weights at some/where")


def test_tied_tasks_none_of_which_does_the_action_are_not_guessed() -> None:
    with pytest.raises(AgentError, match=r"no registered task does what the request asks \('open'\)"):
        AGENT.plan("record 4 demos of opening the incubator")
    assert AGENT.plan("record 4 demos of putting the dish in the incubator").steps[0].args["task_id"] == (
        "pipette/PlacePetriDishInIncubator-v1"
    )


def test_three_hyphenated_words_are_read_as_words_for_the_task() -> None:
    plan = AGENT.plan("render the pull-the-dish-out-of-the-incubator task")  # "pull out", "out of": a removal
    assert plan.steps[0].args["task_id"] == "pipette/RemovePetriDishFromIncubator-v1"


def test_a_task_description_that_names_no_command_is_pointed_at_new_task() -> None:
    with pytest.raises(AgentError, match="reads as something for the robot to do.*new task: put the 15 mL tube"):
        AGENT.plan("put the 15 mL tube in the rack")
    with pytest.raises(AgentError) as plain:
        AGENT.plan("the weather is nice")
    assert "new task" not in str(plain.value)


def test_a_file_a_command_does_not_read_names_only_real_commands() -> None:
    with pytest.raises(AgentError) as exc:
        AGENT.plan("train smolvla on data/pick.h5 for 500 steps")
    assert "pipette answer" not in str(exc.value) and "pipette convert" in str(exc.value)


def test_a_step_whose_output_exists_and_would_stop_says_so(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "datasets" / "pipette_PickUpTestTube-v1" / "raw").mkdir(parents=True)
    plan = AGENT.plan("convert data/PickUpTestTube.h5 and train act on it")
    assert "exists: this step stops unless you say 'overwrite'" in " ".join(plan.steps[0].notes)
    again = AGENT.plan("convert data/PickUpTestTube.h5 and overwrite it, then train act on it")
    assert not any("exists" in n for n in again.steps[0].notes)


def test_a_verbless_clause_after_then_that_names_nothing_completes_the_step_before() -> None:
    plan = AGENT.plan("render the water bath task, then save it to figs/bath.png")
    assert [(s.command, s.args.get("out")) for s in plan.steps] == [("sim render", "figs/bath.png")]


def test_an_arrow_between_paths_says_where_the_first_goes() -> None:
    for request in (
        "augment data/a.h5 -> data/b.h5 for the tube pick-up",
        "augment data/a.h5->data/b.h5 for PickUpTestTube",
    ):
        step = AGENT.plan(request).steps[0]
        assert (step.args["input"], step.args["output"]) == ("data/a.h5", "data/b.h5"), request
        assert "rejected" not in step.args
    removed = AGENT.plan("augment data/a.h5->data/b.h5 for the tube removal").steps[0]
    assert removed.args["task_id"] == "pipette/RemoveTubeFromBalance-v1"  # the arrow is no "place" of the task


def test_an_unknown_task_id_is_refused_as_a_task_not_taken_for_a_file() -> None:
    with pytest.raises(AgentError, match="unknown task 'pipette/CloseIncubatorDoor-v1'; did you mean"):
        AGENT.plan("record 10 demos of pipette/CloseIncubatorDoor-v1 into data/door.h5")
    copied = AGENT.plan("copy CloseCentrifugeLid into a new task mylab/CloseBigCentrifuge-v1")
    assert copied.steps[0].args["new_id"] == "mylab/CloseBigCentrifuge-v1"  # a new id is no unknown task


def test_which_tasks_use_an_asset_is_answered_without_the_word_task() -> None:
    for request in ("does anything use the thermal cycler?", "what in the registry needs a thermal cycler?"):
        plan = AGENT.plan(request)
        assert [(s.command, s.args.get("about")) for s in plan.steps] == [("answer tasks", "thermal cycler")], request


def test_the_same_verb_after_a_comma_with_a_task_of_its_own_is_another_step() -> None:
    plan = AGENT.plan("collect 10 demos of PickUpTestTube, collect 12 demos of CloseCentrifugeLid")
    assert [(s.command, s.args["task_id"], s.args["episodes"]) for s in plan.steps] == [
        ("collect", "pipette/PickUpTestTube-v1", 10),
        ("collect", "pipette/CloseCentrifugeLid-v1", 12),
    ]
    one = AGENT.plan("collect 20 demos of PickUpTestTube, recording at 64 px")
    assert len(one.steps) == 1 and one.steps[0].args["image_size"] == 64


def test_a_video_takes_each_listed_episode_its_view_and_scale_from_later_sentences() -> None:
    plan = AGENT.plan(
        "could you turn episodes 3 and 7 of data/c.h5 into mp4s? just the wrist camera, each view enlarged "
        "three times, put them in videos/"
    )
    assert [s.command for s in plan.steps] == ["data video"]  # "view" is a noun here, not `sim view`
    args = plan.steps[0].args
    assert (args["episode"], args["camera"], args["scale"], args["out"]) == ([3, 7], ["wrist"], 3, "videos/")
    assert plan.unused == []
    listed = AGENT.plan("make gifs of episodes 2, 5 and 9 of data/c.h5 from the top view").steps[0].args
    assert (listed["episode"], listed["camera"]) == ([2, 5, 9], ["top"])


def test_a_flag_named_after_a_negation_is_switched_off() -> None:
    plan = AGENT.plan("check the task files in my_tasks/ without the physics build")
    assert plan.steps[0].args["physics"] is False and plan.unused == []  # "physics build": a name of the flag


def test_a_plural_option_said_in_the_singular_before_its_noun_takes_the_number() -> None:
    with pytest.raises(AgentError, match="--distractors must be <= 6, not 8"):
        AGENT.plan("augment data/shaker_raw.h5 for PlaceFlaskOnShaker with clutter, 8 distractor objects")
    plan = AGENT.plan("augment data/shaker_raw.h5 for PlaceFlaskOnShaker with clutter, 3 distractor objects")
    assert plan.steps[0].args["distractors"] == 3 and plan.unused == []


def test_a_copy_takes_the_task_described_and_a_new_id_is_no_output_file() -> None:
    plan = AGENT.plan("make a copy of the water bath lid task as mylab/DeepBath-v1 in my_tasks/")
    args = plan.steps[0].args
    assert (args["new_id"], args["template"], args["out"]) == (
        "mylab/DeepBath-v1",
        "pipette/OpenWaterBathLid-v1",
        "my_tasks/",
    )
    assert plan.unused == []


def test_showing_an_asset_that_no_words_make_a_task_shows_the_asset() -> None:
    plan = AGENT.plan("list the instrument assets, then show me the spectrophotometer's details as json")
    assert [(s.command, s.args.get("asset_id")) for s in plan.steps] == [
        ("assets list", None),
        ("assets show", "spectrophotometer"),
    ]
    task = AGENT.plan("show me the spectrophotometer lid task").steps[0]
    assert (task.command, task.args["task_id"]) == ("tasks show", "pipette/CloseSpectrophotometerLid-v1")


def test_resuming_a_training_from_its_checkpoint_continues_it() -> None:
    plan = AGENT.plan(
        "ACT training on the augmented spectrophotometer data died at step 9000 of 15000. "
        "pick it up from the last checkpoint"
    )
    assert [(s.command, s.args.get("if_exists")) for s in plan.steps] == [("train", "continue")]
    picked = AGENT.plan("compare raw and augmented act on pick up test tube")  # "pick up" is the task's action
    assert all(s.args.get("if_exists") != "continue" for s in picked.steps)


def test_a_pending_parts_folder_is_its_file_and_removing_it_from_the_file_deletes_the_episode() -> None:
    plan = AGENT.plan(
        "my collect run for the tare-and-weigh protocol got OOM-killed and left data/tw.h5.parts behind; "
        "fold those episodes back into data/tw.h5"
    )
    assert [(s.command, s.args["file"]) for s in plan.steps] == [("data pack", "data/tw.h5")]
    removed = AGENT.plan("episode twelve in data/f.h5 is junk, please remove it from the file").steps
    assert [(s.command, s.args["file"], s.args["index"]) for s in removed] == [("data delete-episode", "data/f.h5", 12)]


def test_protocols_are_listed_and_control_steps_name_no_task() -> None:
    assert [s.command for s in AGENT.plan("list the protocols").steps] == ["answer tasks"]
    plan = AGENT.plan(
        "how fast does the scene for closing the thermal cycler lid step? time 120 control steps at 96 px"
    )
    step = plan.steps[0]
    assert len(plan.steps) == 1 and (step.args["task_id"], step.args["steps"]) == (
        "generated/CloseThermalCyclerLid-v1",
        120,
    )


def test_the_agent_names_pending_parts_folders_as_the_store_does() -> None:
    from pipette_cli.agent.arguments import PARTS_SUFFIX
    from pipette_cli.demos.store import parts_dir

    assert parts_dir(Path("data/x.h5")) == Path(f"data/x.h5{PARTS_SUFFIX}")


def test_a_length_goes_to_the_option_in_metres_its_words_name_and_a_count_per_demo_said_after() -> None:
    plan = AGENT.plan(
        "augment data/t.h5 for the tube pick-up with object shifts only: six draws per demo, 3 cm range, "
        "up to 30 degrees of yaw"
    )
    args = plan.steps[0].args
    assert (args["variants"], args["object_xy"], args["object_yaw"]) == ("object*6", 0.03, 30.0)
    radius = AGENT.plan("augment data/t.h5 for PickUpTestTube with camera variants, 5 cm camera radius").steps[0]
    assert radius.args["camera_radius"] == 0.05 and "wrist_radius" not in radius.args
    with pytest.raises(AgentError, match="5 of each"):  # several values: no count is guessed for each, it is asked
        AGENT.plan("augment data/t.h5 for PickUpTestTube with object pose jitter and camera shake, 5 variants per demo")


def test_an_option_taking_several_tasks_takes_each_task_described_in_a_list() -> None:
    plan = AGENT.plan("train act on the tube pick-up and the centrifuge lid closing")
    assert plan.steps[0].args["tasks"] == "pipette/PickUpTestTube-v1,pipette/CloseCentrifugeLid-v1"
    one = AGENT.plan("train act on PickUpTestTube with batch size 8 and 2 threads")
    assert one.steps[0].args["tasks"] == "pipette/PickUpTestTube-v1"


def test_episodes_run_against_a_server_are_an_evaluation_of_their_own() -> None:
    plan = AGENT.plan(
        "spin up a server for ckpt/act/pretrained_model, run 20 episodes of the centrifuge-opening task against it "
        "at 64 px into evals/open, and then give me the results table"
    )
    assert [s.command for s in plan.steps] == ["serve", "eval", "eval report"]
    assert plan.steps[1].args["endpoint"] == [StepRef(from_step=1)] and plan.steps[1].args["episodes"] == 20


def test_a_question_about_each_thing_the_step_before_lists_is_no_step_of_its_own() -> None:
    plan = AGENT.plan("which frozen evaluation suites are there, and how many episodes does each one have?")
    assert [s.command for s in plan.steps] == ["tasks suites"] and plan.unused == []  # not a scan of every .h5 here
    asked = AGENT.plan("list the suites and how many demos are in data/x.h5")
    assert [s.command for s in asked.steps] == ["tasks suites", "answer demos"]


def test_comparing_them_reports_every_earlier_evaluation_and_the_same_suite_is_carried() -> None:
    plan = AGENT.plan(
        "eval ckpt/raw/pretrained_model on the CPU reproduction suite, test tube task only, out evals/raw; then eval "
        "ckpt/aug/pretrained_model on the same suite and task, out evals/aug; then compare them and save the table "
        "to results/tube"
    )
    assert [s.command for s in plan.steps] == ["eval", "eval", "eval report"]
    assert plan.steps[1].args["suite_id"] == plan.steps[0].args["suite_id"] == "pipette/CpuReproduction-v1"
    report = plan.steps[2].args
    assert report["folders"] == [StepRef(from_step=1), StepRef(from_step=2)] and report["out"] == "results/tube"
    assert "same" not in plan.unused


def test_a_path_right_after_write_is_where_the_command_writes() -> None:
    plan = AGENT.plan(
        "augment data/v.h5 for the vortex protocol with three clutter draws per demo, keep the rejects in "
        "data/rej.h5 and write data/v_clutter.h5"
    )
    args = plan.steps[0].args
    assert (args["input"], args["output"], args["rejected"]) == ("data/v.h5", "data/v_clutter.h5", "data/rej.h5")
    noun = AGENT.plan("convert the output data/x.h5").steps[0].args  # "output" here is a noun: the input
    assert noun["inputs"] == ["data/x.h5"] and "root" not in noun
    video = AGENT.plan("make a video of episode 4 of data/a.h5, top camera only")
    assert video.steps[0].args["camera"] == ["top"] and video.unused == []
