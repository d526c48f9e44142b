"""`pipette eval`: decoding (interpolation, chunks, gripper hysteresis, safe hold), a served tiny
ACT end to end with JSON logs, in-process mode, and `eval report`."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from pipette_cli.errors import PipetteError
from pipette_cli.evaluation.evaluate import Gripper, _commanded, run_episode
from pipette_cli.evaluation.settings import DecodeConfig
from pipette_cli.registry import load_registry
from pipette_cli.sim.env import PipetteEnv

pytestmark = pytest.mark.render
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fixtures" / "policy"))
from tiny_policy import make_tiny_act  # noqa: E402

TASK = load_registry().get("PickUpTestTube")


def test_act_interpolation_reaches_the_goal_at_the_next_query() -> None:
    q_prev, q_curr = np.zeros(7), np.ones(7)
    assert [float(_commanded(q_prev, q_curr, m, 3)[0]) for m in (1, 2, 3, 4)] == pytest.approx([1 / 3, 2 / 3, 1, 1])


def test_gripper_threshold_and_pi0_hysteresis() -> None:
    plain = Gripper(DecodeConfig.for_policy("act"))
    assert [plain(u) for u in (0.6, 0.5, 0.49, 0.5)] == [1.0, 1.0, 0.0, 1.0]
    pi0 = Gripper(DecodeConfig.for_policy("pi0"))
    assert [pi0(u) for u in (0.5, 0.46, 0.45, 0.5, 0.54, 0.55, 0.46)] == [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0]
    config = DecodeConfig.for_policy("pi0")
    assert (config.timeout_ms, config.max_consecutive_failures, config.chunked) == (300_000, 20, True)
    with pytest.raises(PipetteError, match="unknown policy type 'rt2'"):
        DecodeConfig.for_policy("rt2")


class Scripted:
    """A policy that answers fixed actions (or chunks) and can fail on demand."""

    def __init__(self, action: np.ndarray, *, chunk: int = 0, fail_after: int | None = None) -> None:
        self.action, self.chunk, self.fail_after, self.calls = action, chunk, fail_after, 0

    def act(self, observation, *, task, reset, chunk):
        self.calls += 1
        assert observation["observation.images.top"].shape == (3, 24, 24) and task == TASK.instruction
        if self.fail_after is not None and self.calls > self.fail_after:
            raise PipetteError("no reply")
        return np.tile(self.action, (self.chunk, 1)) if chunk else self.action


def test_queries_at_10_hz_and_safe_hold_after_six_failures() -> None:
    env = PipetteEnv(TASK, image_size=24)
    home = np.asarray(TASK.embodiment.initial_joints)
    source = Scripted(np.append(home, 1.0), fail_after=2)
    log = run_episode(env, source, DecodeConfig.for_policy("act"), episode=0, seed=0)
    env.close()
    assert log.policy_queries == 2 and log.failed_queries == 6 and log.safe_hold
    assert source.calls == 8  # 2 answers, then 6 failures, then no more queries: holding
    assert not log.success and log.control_steps == 7 * 30  # held until the 7 s timeout
    assert log.control_hz == pytest.approx(30, rel=0.01)


def test_chunk_policy_executes_its_chunk() -> None:
    env = PipetteEnv(TASK, image_size=24)
    target = np.append(np.asarray(TASK.embodiment.initial_joints) + 0.05, 0.0)
    source = Scripted(target, chunk=5)
    log = run_episode(env, source, DecodeConfig.for_policy("smolvla"), episode=0, seed=1)
    np.testing.assert_allclose(env.world.data.ctrl[env.world.arm_actuator_ids], target[:-1])
    assert env.world.data.ctrl[env.world.gripper_actuator_id] == 0.0  # u = 0 closes
    env.close()
    assert log.policy_queries == (log.control_steps + 2) // 3


@pytest.fixture(scope="module")
def tiny_act(tmp_path_factory) -> Path:
    return make_tiny_act(tmp_path_factory.mktemp("policy") / "act", image_size=32)


def test_served_policy_two_episodes_with_json_logs(run_cli, tiny_act, tmp_path) -> None:
    from pipette_cli.serving.server import LeRobotRunner, PolicyServer, serving_in_thread

    with serving_in_thread(PolicyServer(LeRobotRunner(tiny_act, device="cpu"), "tcp://127.0.0.1:0")) as server:
        result = run_cli(
            "eval",
            "PickUpTestTube",
            "--endpoint",
            server.endpoint,
            "--episodes",
            "2",
            "--image-size",
            "32",
            "--out",
            tmp_path / "act_raw",
            "--json",
        )
    assert result.exit_code == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["episodes"] == 2 and summary["success_rate"] == summary["successes"] / 2
    logs = [json.loads(p.read_text()) for p in sorted((tmp_path / "act_raw").glob("episode_*.json"))]
    assert len(logs) == 2 and [log["seed"] for log in logs] == [0, 1]
    for log in logs:
        assert log["policy_queries"] > 50 and log["failed_queries"] == 0 and not log["safe_hold"]
        assert log["control_hz"] == pytest.approx(30, rel=0.01) and log["policy_hz"] == pytest.approx(10, rel=0.05)
        assert log["gripper_thresholds"] == {"open": 0.5, "stay_open": 0.5} and "height_gain" in log["metrics"]
        assert log["success"] or log["failure_reason"]


def test_in_process_mode_and_report(run_cli, tiny_act, tmp_path) -> None:
    result = run_cli(
        "eval",
        "PickUpTestTube",
        "--policy",
        tiny_act,
        "--device",
        "cpu",
        "--episodes",
        "1",
        "--image-size",
        "32",
        "--out",
        tmp_path / "runs" / "act_aug",
        "--dataset-version",
        "augmented",
    )
    assert result.exit_code == 0, result.stderr
    assert "SR = 0/1 = 0.0 % (95 % CI 0.0-79.3)" in result.stdout  # an untrained policy lifts nothing
    (tmp_path / "runs" / "act_aug" / "summary.json").unlink()  # the report reads the episode logs
    (tmp_path / "runs" / "act_raw").mkdir()
    (tmp_path / "runs" / "act_raw" / "summary.json").write_text(
        json.dumps(
            {
                "task": "pipette/PickUpTestTube-v1",
                "policy_type": "act",
                "dataset_version": "raw",
                "episodes": 4,
                "success_rate": 0.75,
            }
        )
    )
    report = run_cli("eval", "report", tmp_path / "runs", "--out", tmp_path / "table")
    assert report.exit_code == 0, report.stderr
    assert (
        "| pipette/PickUpTestTube-v1 | act | 3/4 (75 %, 30-95) | 0/1 (0 %, 0-79) | -75 pt | Fisher p = 0.4 (Holm 0.4) | no |"
        in report.stdout
    )
    assert (
        (tmp_path / "table.csv")
        .read_text()
        .splitlines()[1]
        .startswith("pipette/PickUpTestTube-v1,act,augmented,1,0,0.0000,0.0000,0.79")
    )
    data = json.loads((tmp_path / "table.json").read_text())
    assert data["comparisons"][0]["test"] == "fisher_exact" and data["comparisons"][0]["p_value"] == pytest.approx(0.4)
    assert (tmp_path / "table.png").stat().st_size > 1000 and (tmp_path / "table.md").read_text().startswith("| task |")


def test_eval_needs_exactly_one_policy_source(run_cli) -> None:
    result = run_cli("eval", "PickUpTestTube", "--episodes", "1")
    assert result.exit_code == 1 and "exactly one of --endpoint" in result.stderr
