"""``pipette eval``: `report` as its own command (help included), and the policy type read from
the checkpoint's config.json. No policy is loaded: the checkpoints hold only a config.json."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pipette_cli.errors import PipetteError
from pipette_cli.evaluation import runner as lerobot_runner
from pipette_cli.evaluation.settings import resolve_policy_type


def checkpoint(folder: Path, policy_type: str) -> Path:
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps({"type": policy_type, "chunk_size": 50}))
    return folder


def test_eval_report_help_is_the_report_help(run_cli) -> None:
    result = run_cli("eval", "report", "--help")
    assert result.exit_code == 0
    assert "pipette eval report [OPTIONS]" in result.stdout and "Tabulate evaluation results" in result.stdout
    assert "--endpoint" not in result.stdout
    plain = run_cli("eval", "--help")
    assert plain.exit_code == 0 and "--endpoint" in plain.stdout and "pipette eval [OPTIONS]" in plain.stdout


def test_eval_report_tabulates_and_needs_a_folder(run_cli, tmp_path: Path) -> None:
    (tmp_path / "runs" / "act_raw").mkdir(parents=True)
    (tmp_path / "runs" / "act_raw" / "summary.json").write_text(
        json.dumps(
            {
                "task": "pipette/PickUpTestTube-v1",
                "policy_type": "act",
                "dataset_version": "raw",
                "episodes": 4,
                "success_rate": 0.5,
            }
        )
    )
    result = run_cli("eval", "report", tmp_path / "runs")
    assert result.exit_code == 0, result.stderr
    assert "| pipette/PickUpTestTube-v1 | act | 2/4 (50 %, 15-85) | - |" in result.stdout  # from the summary alone
    assert run_cli("eval", "report").exit_code == 2  # a usage error: no folder
    odd = tmp_path / "runs[" / "old]"  # brackets in an error message are printed, not read as rich markup
    odd.mkdir(parents=True)
    missing = run_cli("eval", "report", odd)
    assert missing.exit_code == 1 and f"error: {odd}: no evaluation results" in " ".join(missing.stderr.split())
    extra = run_cli("eval", "PickUpTestTube", "leftover", "--endpoint", "tcp://127.0.0.1:1")
    assert extra.exit_code == 2 and "leftover" in extra.stderr


@pytest.fixture
def captured(monkeypatch: pytest.MonkeyPatch) -> dict:
    """Replace loading and running the policy: record the decoding config eval chose."""
    seen: dict = {}

    def fake_evaluate_runs(runs, source, settings, **kwargs):
        seen["policy_type"] = settings.config.policy_type
        task = runs[0].task.id
        return lerobot_runner.EvalResult(
            {
                task: {
                    "task": task,
                    "policy_type": settings.config.policy_type,
                    "episodes": 1,
                    "successes": 0,
                    "success_rate": 0.0,
                    "success_ci95": [0.0, 0.79],
                }
            }
        )

    monkeypatch.setattr(lerobot_runner, "evaluate_runs", fake_evaluate_runs)
    return seen


def test_eval_reads_the_policy_type_from_the_checkpoint(run_cli, captured, tmp_path: Path) -> None:
    smolvla = checkpoint(tmp_path / "smolvla", "smolvla")
    result = run_cli("eval", "PickUpTestTube", "--policy", smolvla, "--episodes", "1", "--json")
    assert result.exit_code == 0, result.stderr
    assert captured["policy_type"] == "smolvla" and json.loads(result.stdout)["policy_type"] == "smolvla"
    agreeing = run_cli("eval", "PickUpTestTube", "--policy", smolvla, "--policy-type", "smolvla", "--episodes", "1")
    assert agreeing.exit_code == 0, agreeing.stderr


def test_a_lost_server_exits_3_an_interrupt_130(run_cli, monkeypatch, tmp_path: Path) -> None:
    """The documented codes: a script tells a run stopped with a partial summary from a finished one."""
    from pipette_cli.evaluation.evaluate import ServerLost

    def lost(runs, source, settings, **kwargs):
        raise ServerLost("no connection to tcp://127.0.0.1:1 for 5 s; stopped after 2 of 4 episodes", {})

    def interrupted(runs, source, settings, *, stop, **kwargs):
        return lerobot_runner.EvalResult(new_episodes=2, interrupted=True)

    args = ("eval", "PickUpTestTube", "--policy", checkpoint(tmp_path / "act", "act"), "--episodes", "4")
    monkeypatch.setattr(lerobot_runner, "evaluate_runs", lost)
    result = run_cli(*args)
    assert result.exit_code == 3 and "error: no connection to tcp://127.0.0.1:1" in result.stderr
    monkeypatch.setattr(lerobot_runner, "evaluate_runs", interrupted)
    result = run_cli(*args)
    assert result.exit_code == 130 and "interrupted after 2 new episodes; summaries written" in result.stderr


def test_eval_refuses_a_checkpoint_that_reads_another_image_size(run_cli, captured, tmp_path: Path) -> None:
    act = checkpoint(tmp_path / "act", "act")
    features = {f"observation.images.{c}": {"type": "VISUAL", "shape": [3, 64, 64]} for c in ("top", "main")}
    (act / "config.json").write_text(json.dumps({"type": "act", "input_features": features}))
    result = run_cli("eval", "PickUpTestTube", "--policy", act, "--episodes", "1")  # the task renders 400 px
    assert result.exit_code == 1 and "policy_type" not in captured
    assert (
        f"the policy in {act} reads top images of 64x64, but this evaluation renders 400x400 (--image-size"
        in " ".join(result.stderr.split())
    )
    assert run_cli("eval", "PickUpTestTube", "--policy", act, "--episodes", "1", "--image-size", "64").exit_code == 0


def test_eval_refuses_a_policy_type_that_contradicts_the_checkpoint(run_cli, captured, tmp_path: Path) -> None:
    pi0 = checkpoint(tmp_path / "pi0", "pi0")
    result = run_cli("eval", "PickUpTestTube", "--policy", pi0, "--policy-type", "act", "--episodes", "1")
    assert result.exit_code == 1 and "policy_type" not in captured
    assert "--policy-type act contradicts" in result.stderr and "'pi0'" in result.stderr


def test_eval_takes_a_training_run_folder_as_its_last_checkpoint(run_cli, captured, tmp_path: Path) -> None:
    run = tmp_path / "act" / "pipette_PickUpTestTube-v1_raw"
    checkpoint(run / "checkpoints" / "last" / "pretrained_model", "pi0")
    result = run_cli("eval", "PickUpTestTube", "--policy", run, "--policy-type", "act", "--episodes", "1")
    said = " ".join(result.stderr.split())
    assert result.exit_code == 1 and f"policy: {run}/checkpoints/last/pretrained_model" in said
    assert f"contradicts {run}/checkpoints/last/pretrained_model/config.json" in said  # the run's checkpoint read
    result = run_cli("eval", "PickUpTestTube", "--policy", tmp_path / "act" / "nowhere", "--episodes", "1")
    assert result.exit_code == 1 and "no such policy folder" in result.stderr and "policy_type" not in captured


def test_resolve_policy_type(tmp_path: Path) -> None:
    assert resolve_policy_type(None, None) == "act"  # a server: nothing to read
    assert resolve_policy_type("pi0", None) == "pi0"
    assert resolve_policy_type(None, checkpoint(tmp_path / "p", "pi0")) == "pi0"
    with pytest.raises(
        PipetteError, match="policy type 'diffusion' cannot be evaluated; expected one of act, smolvla, pi0"
    ):
        resolve_policy_type(None, checkpoint(tmp_path / "d", "diffusion"))
    with pytest.raises(PipetteError, match="not a LeRobot policy folder \\(no config.json\\)"):
        resolve_policy_type(None, tmp_path)
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "config.json").write_text("{}")
    with pytest.raises(PipetteError, match="no policy 'type' field"):
        resolve_policy_type(None, tmp_path / "broken")


def test_eval_names_what_is_wrong_with_a_suite_request(run_cli, tmp_path: Path) -> None:
    unknown = run_cli("eval", "--suite", "PaperBenchmrk", "--endpoint", "tcp://127.0.0.1:1")
    assert (
        unknown.exit_code == 1
        and "unknown suite 'PaperBenchmrk'; did you mean 'pipette/PaperBenchmark-v1'" in unknown.stderr
    )
    fixed = run_cli(
        "eval", "--suite", "PaperBenchmark", "--endpoint", "tcp://127.0.0.1:1", "--episodes", "5", "--seed", "3"
    )
    assert fixed.exit_code == 1 and "--episodes, --seed: the suite fixes seeds and image size" in fixed.stderr
    outside = run_cli(
        "--registry-dir",
        Path(__file__).parents[1] / "fixtures" / "demos" / "registry",
        "eval",
        "HoldTube",
        "--suite",
        "PaperBenchmark",
        "--endpoint",
        "tcp://127.0.0.1:1",
    )
    assert (
        outside.exit_code == 1
        and "task testlab/HoldTube-v1 is not in suite pipette/PaperBenchmark-v1" in outside.stderr
    )
    nothing = run_cli("eval", "--endpoint", "tcp://127.0.0.1:1")
    assert nothing.exit_code == 1 and "name a task or a suite" in nothing.stderr


def test_eval_refuses_a_robot_that_cannot_do_the_task_before_connecting(run_cli, tmp_path: Path) -> None:
    out = tmp_path / "ev"
    result = run_cli(
        "eval",
        "CloseCentrifugeLid",
        "--robot",
        "piper",
        "--endpoint",
        "tcp://127.0.0.1:1",
        "--episodes",
        "1",
        "--out",
        out,
    )
    said = " ".join(result.stderr.split())
    assert result.exit_code == 1 and "on the agilex_piper: reach: the push on 'centrifuge/lid_hinge'" in said
    assert not out.exists()


def test_eval_gives_up_on_a_server_that_never_answers(run_cli, tmp_path: Path) -> None:
    import socket

    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    result = run_cli(
        "eval",
        "PickUpTestTube",
        "--endpoint",
        f"tcp://127.0.0.1:{port}",
        "--connect-timeout",
        "0.5",
        "--out",
        tmp_path / "run",
    )
    assert result.exit_code == 1
    assert (
        f"no policy server answers at tcp://127.0.0.1:{port} (waited 0.5 s); start `pipette serve` first"
        in result.stderr
    )


def test_tasks_suites_lists_the_frozen_suites(run_cli) -> None:
    result = run_cli("tasks", "suites", "--json")
    assert result.exit_code == 0, result.stderr
    suites = {s["id"]: s for s in json.loads(result.stdout)}
    cpu = suites["pipette/CpuReproduction-v1"]
    assert (cpu["episodes"], cpu["image_size"], len(cpu["tasks"])) == (200, 64, 4) and len(cpu["sha256"]) == 64
    assert suites["pipette/PaperBenchmark-v1"]["episodes"] == 12 * 75
