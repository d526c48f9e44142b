"""Evaluation at benchmark scale: suites, resume after SIGKILL, parallel workers, dead and slow
servers, stage progress. Episodes are short (the fixture tasks time out after 0.5-0.6 s)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
sys.path.insert(0, str(FIXTURES / "policy"))

from tiny_policy import FeedbackSource, FixedRunner  # noqa: E402

from pipette_cli.evaluation.evaluate import ServerLost  # noqa: E402
from pipette_cli.evaluation.runner import PolicySource, TaskRun, evaluate_runs  # noqa: E402
from pipette_cli.evaluation.settings import DecodeConfig, EvalSettings  # noqa: E402
from pipette_cli.evaluation.suites import episode_plan, load_suites  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.serving.server import PolicyServer, serving_in_thread  # noqa: E402

pytestmark = [pytest.mark.render, pytest.mark.timeout(300)]
DIRS = [FIXTURES / "demos" / "registry", FIXTURES / "eval" / "registry"]
REGISTRY = load_registry(DIRS)
SUITE = load_suites(REGISTRY, DIRS).get("testlab/Tiny-v1")
HOLD = [0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785, 1.0]  # HoldTube's initial joints, gripper open
ACT = DecodeConfig.for_policy("act")


def suite_runs(out: Path) -> list[TaskRun]:
    return [
        TaskRun(REGISTRY.get(t), out / t.replace("/", "_"), tuple(eps)) for t, eps in episode_plan(SUITE.spec).items()
    ]


def logs(folder: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(folder.glob("episode_*.json"))]


def test_a_suite_runs_the_same_episodes_with_one_or_two_workers(tmp_path) -> None:
    settings = EvalSettings(ACT, SUITE.spec.image_size, SUITE.spec.render_profile, "raw", SUITE.record())
    one = evaluate_runs(suite_runs(tmp_path / "one"), FeedbackSource(), settings, workers=1)
    two = evaluate_runs(suite_runs(tmp_path / "two"), FeedbackSource(), settings, workers=2)
    assert one.new_episodes == two.new_episodes == 7
    for run in suite_runs(tmp_path / "one"):
        a, b = logs(run.folder), logs(tmp_path / "two" / run.folder.name)
        assert [(x["seed"], x["instruction"]) for x in a] == [(e.seed, e.instruction) for e in run.episodes]
        for x, y in zip(a, b, strict=True):  # identical episodes, whichever worker ran them
            x.pop("runtime_s"), y.pop("runtime_s")
            assert x == y
    hold = two.summaries["testlab/HoldTube-v1"]
    assert hold["suite"] == {"id": "testlab/Tiny-v1", "version": 1, "sha256": SUITE.sha256}
    assert [x["instruction"] for x in logs(tmp_path / "two" / "testlab_HoldTube-v1")] == [
        "Hold still next to the test tube.",
        "Stay beside the tube.",
    ] * 2
    env = hold["environments"][0]
    assert (
        env["gl_backend"] == os.environ["MUJOCO_GL"]
        and env["mujoco"]
        and (env["git_commit"] == "unknown" or len(env["git_commit"]) == 40)
    )
    assert env["gl_renderer"] != "unknown"
    staged = two.summaries["testlab/StagedHoldTube-v1"]
    assert staged["mean_progress"] == 0.5 and staged["final_stage_counts"] == {"1": 3}
    assert all(
        x["progress"] == 0.5 and x["metrics"]["stages"] == 2
        for x in logs(tmp_path / "two" / "testlab_StagedHoldTube-v1")
    )


def _eval_command(endpoint: str, out: Path, episodes: int) -> list[str]:
    return [
        sys.executable,
        "-m",
        "pipette_cli.cli.main",
        "--registry-dir",
        str(DIRS[0]),
        "eval",
        "HoldTube",
        "--endpoint",
        endpoint,
        "--image-size",
        "24",
        "--episodes",
        str(episodes),
        "--out",
        str(out),
        "--json",
    ]


def test_a_killed_evaluation_resumes_without_losing_or_repeating_an_episode(tmp_path) -> None:
    out = tmp_path / "run"
    runner = FixedRunner(HOLD, image_size=24)
    with serving_in_thread(PolicyServer(runner, "tcp://127.0.0.1:0")) as server:
        command = _eval_command(server.endpoint, out, 24)
        proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        deadline = time.monotonic() + 120
        while len(list(out.glob("episode_*.json"))) < 4 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGKILL)  # mid-episode: no chance to clean up
        proc.wait()
        before = {p.name: p.stat().st_mtime_ns for p in out.glob("episode_*.json")}
        assert 4 <= len(before) < 24
        calls_before = runner.calls
        rerun = subprocess.run(command, capture_output=True, text=True, timeout=240)
    assert rerun.returncode == 0, rerun.stderr
    assert f"{len(before)} episodes already logged; {24 - len(before)} to go" in " ".join(rerun.stderr.split())
    final = logs(out)
    assert [x["episode"] for x in final] == list(range(24)) and [x["seed"] for x in final] == list(range(24))
    assert {
        p.name: p.stat().st_mtime_ns for p in out.glob("episode_*.json") if p.name in before
    } == before  # none rewritten
    assert runner.calls - calls_before == sum(x["policy_queries"] for x in final[len(before) :])  # none played twice
    assert not list(out.glob("*.tmp"))
    summary = json.loads(rerun.stdout)
    assert summary["episodes"] == summary["planned"] == 24 and summary["complete"]


def _serve_in_process(tmp_path: Path, *extra: str) -> tuple[subprocess.Popen, str]:
    proc = subprocess.Popen(
        [
            sys.executable,
            str(FIXTURES / "policy" / "serve_fixed.py"),
            "--action",
            ",".join(map(str, HOLD)),
            "--image-size",
            "24",
            *extra,
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    endpoint = proc.stdout.readline().strip()
    assert endpoint.startswith("tcp://"), endpoint
    return proc, endpoint


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)], ids=["sigint", "sigterm"])
def test_an_interrupted_evaluation_writes_its_partial_summary_and_exits_non_zero(tmp_path, signum, code) -> None:
    out = tmp_path / "run"
    with serving_in_thread(PolicyServer(FixedRunner(HOLD, image_size=24), "tcp://127.0.0.1:0")) as server:
        proc = subprocess.Popen(
            _eval_command(server.endpoint, out, 200), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        deadline = time.monotonic() + 120
        while len(list(out.glob("episode_*.json"))) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == code, stderr
    assert "summaries written; run the same command again to resume" in " ".join(stderr.split())
    assert stdout == ""  # no summary on stdout: a script reads the exit code, not a half result
    summary = json.loads((out / "summary.json").read_text())
    assert not summary["complete"] and 2 <= summary["episodes"] < 200 and summary["episodes"] == len(logs(out))


def test_a_killed_server_stops_the_run_within_seconds_with_a_partial_summary(run_cli, tmp_path) -> None:
    server, endpoint = _serve_in_process(tmp_path)
    out = tmp_path / "run"
    killed: list[float] = []

    def kill_after_three_episodes() -> None:
        while len(list(out.glob("episode_*.json"))) < 3:
            time.sleep(0.02)
        server.kill()
        killed.append(time.time())

    threading.Thread(target=kill_after_three_episodes, daemon=True).start()
    try:
        result = run_cli(
            "--registry-dir",
            DIRS[0],
            "eval",
            "HoldTube",
            "--endpoint",
            endpoint,
            "--image-size",
            "24",
            "--episodes",
            "200",
            "--out",
            out,
        )
        ended = time.time()
    finally:
        server.kill()
        server.wait()
    assert result.exit_code == 3  # documented: stopped by a lost server, partial summary written
    [line] = [x for x in result.stderr.splitlines() if "error:" in x] or [""]
    message = " ".join(result.stderr.split())
    assert "is down or unreachable; safe hold applied in testlab/HoldTube-v1 episode" in message
    assert "rerun the same command to resume" in message and line
    summary = json.loads((out / "summary.json").read_text())
    stopped = summary["stopped"]
    assert not summary["complete"] and 3 <= summary["episodes"] < 200 and summary["episodes"] == len(logs(out))
    assert stopped["hold"][-1] == 1.0 and len(stopped["hold"]) == 8  # [q_now, open]
    detection = stopped["held_at"] - killed[0]
    assert 0 < detection < 10, detection  # the default: unreachable for 5 s
    assert ended - stopped["held_at"] < 30
    assert not (out / f"episode_{stopped['episode']:04d}.json").exists()  # the held episode is not counted


def test_a_slow_server_is_not_declared_dead(tmp_path) -> None:
    server, endpoint = _serve_in_process(tmp_path, "--slow-every", "4", "--slow-s", "2.0")
    try:
        run = TaskRun(
            REGISTRY.get("HoldTube"), tmp_path / "run", tuple(episode_plan(SUITE.spec)["testlab/HoldTube-v1"][:1])
        )
        source = PolicySource(endpoints=(endpoint,), dead_after_s=0.5)  # far below the 2 s the policy takes
        started = time.monotonic()
        result = evaluate_runs([run], source, EvalSettings(ACT, 24), workers=1)
        elapsed = time.monotonic() - started
    finally:
        server.kill()
        server.wait()
    [log] = logs(tmp_path / "run")
    assert log["policy_queries"] == 5 and log["failed_queries"] == 0 and not log["safe_hold"]
    assert elapsed > 2.0 and result.summaries["testlab/HoldTube-v1"]["stopped"] is None


def test_server_lost_is_raised_by_the_library_with_the_record(tmp_path) -> None:
    server, endpoint = _serve_in_process(tmp_path)
    server.kill()
    server.wait()
    run = TaskRun(REGISTRY.get("HoldTube"), tmp_path / "run", tuple(episode_plan(SUITE.spec)["testlab/HoldTube-v1"]))
    with pytest.raises(ServerLost, match="stopped after 0 of 4 episodes") as info:
        evaluate_runs([run], PolicySource(endpoints=(endpoint,), dead_after_s=0.5), EvalSettings(ACT, 24))
    assert info.value.record["episode"] == 0 and info.value.record["step"] == 0
    assert not list((tmp_path / "run").glob("episode_*.json")) and not (tmp_path / "run" / "summary.json").exists()


def test_pipette_eval_suite_end_to_end_then_report(run_cli, tmp_path) -> None:
    registry_args = ("--registry-dir", DIRS[0], "--registry-dir", DIRS[1])
    with serving_in_thread(PolicyServer(FixedRunner(HOLD, image_size=32), "tcp://127.0.0.1:0")) as wrong:
        refused = run_cli(
            *registry_args, "eval", "--suite", "Tiny-v1", "--endpoint", wrong.endpoint, "--out", tmp_path / "x"
        )
    assert refused.exit_code == 1 and "reads top images of 32x32, but this evaluation renders 24x24" in refused.stderr
    with serving_in_thread(PolicyServer(FixedRunner(HOLD, image_size=24), "tcp://127.0.0.1:0")) as server:
        args = (
            *registry_args,
            "eval",
            "--suite",
            "Tiny-v1",
            "--endpoint",
            server.endpoint,
            "--out",
            tmp_path / "evals",
        )
        result = run_cli(*args, "--json")
        again = run_cli(*args)
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["suite"]["id"] == "testlab/Tiny-v1" and [s["episodes"] for s in data["summaries"]] == [4, 3]
    assert again.exit_code == 0 and "7 episodes already logged; 0 to go" in again.stderr
    assert "testlab/StagedHoldTube-v1: SR = 0/3 = 0.0 % (95 % CI 0.0-56.1), stage progress 0.50" in again.stdout
    for summary in (tmp_path / "evals").glob("*/summary.json"):
        summary.unlink()
    report = run_cli("eval", "report", tmp_path / "evals", "--out", tmp_path / "table")
    assert report.exit_code == 0, report.stderr
    assert "| testlab/StagedHoldTube-v1 | act | 0/3 (0 %, 0-56), progress 0.50 | - |" in report.stdout
    assert sorted(p.suffix for p in tmp_path.glob("table.*")) == [".csv", ".json", ".md", ".png"]


def test_a_shifted_suite_draws_each_episodes_conditions_from_its_seed(tmp_path) -> None:
    shifted = load_suites(REGISTRY, DIRS).get("testlab/TinyShifted-v1")
    runs = {
        name: [TaskRun(REGISTRY.get(t), tmp_path / name / t.replace("/", "_"), tuple(e)) for t, e in plan.items()]
        for name, plan in (
            ("nominal", episode_plan(SUITE.spec)),
            ("one", episode_plan(shifted.spec)),
            ("two", episode_plan(shifted.spec)),
        )
    }
    nominal = EvalSettings(ACT, SUITE.spec.image_size, SUITE.spec.render_profile, "raw", SUITE.record())
    settings = EvalSettings(ACT, shifted.spec.image_size, shifted.spec.render_profile, "raw", shifted.record())
    evaluate_runs(runs["nominal"], FeedbackSource(), nominal, workers=1)
    evaluate_runs(runs["one"], FeedbackSource(), settings, workers=1)
    evaluate_runs(runs["two"], FeedbackSource(), settings, workers=2)
    folder = "testlab_HoldTube-v1"
    base, one, two = (logs(tmp_path / name / folder) for name in ("nominal", "one", "two"))
    for x, y in zip(one, two, strict=True):  # same seed, same conditions and episode, whichever worker
        x.pop("runtime_s"), y.pop("runtime_s")
        assert x == y
    assert all(x["conditions"] == {} for x in base)
    drawn = [x["conditions"] for x in one]
    assert all(set(c) == {"lighting", "camera_pose", "object_pose", "surface_color"} for c in drawn)
    assert all(0.5 <= c["lighting"]["scale_used"] <= 1.3 for c in drawn)
    assert all(set(c["camera_pose"]["delta"]) == {"top", "main", "wrist"} for c in drawn)
    assert len({c["lighting"]["scale_used"] for c in drawn}) == len(drawn)  # each episode its own draw
    for c in drawn:  # placed anew within 1.5 times the task's +-4 cm around the nominal x = 0.5
        offset = c["object_pose"]
        assert offset["object"] == "tube" and abs(offset["dx"]) <= 0.04 * 2.5 and abs(offset["dy"]) <= 0.04 * 2.5
    # the policy sees the changed world: its image-driven actions, and so the episodes, differ
    assert [x["metrics"] for x in base] != [x["metrics"] for x in one]
    manifest = json.loads((tmp_path / "one" / folder / "run.json").read_text())
    assert [c["type"] for c in manifest["conditions"]] == ["lighting", "camera_pose", "object_pose", "surface_color"]
    assert manifest["suite"]["sha256"] == shifted.sha256 != SUITE.sha256


def test_a_suite_with_distractors_puts_them_clear_of_the_experts_path_each_episode(tmp_path) -> None:
    from pipette_cli.specs.perturbations import DistractorSpec, ObjectPoseSpec
    from pipette_cli.specs.suite import SuiteSpec

    base = load_suites(REGISTRY, DIRS).get("testlab/TinyShifted-v1").spec
    spec = SuiteSpec.model_validate(
        {
            **base.model_dump(),
            "id": "testlab/TinyClutter-v1",
            "tasks": [t.model_dump() for t in base.tasks[:1]],
            "perturbations": [ObjectPoseSpec(task_range=1.0), DistractorSpec(count=2)],
        }
    )
    settings = EvalSettings(ACT, spec.image_size, spec.render_profile, "raw", None)
    plans = episode_plan(spec)
    for name, workers in (("one", 1), ("two", 2)):
        runs = [TaskRun(REGISTRY.get(t), tmp_path / name / t.replace("/", "_"), tuple(e)) for t, e in plans.items()]
        evaluate_runs(runs, FeedbackSource(), settings, workers=workers)
    one, two = (logs(tmp_path / name / "testlab_HoldTube-v1") for name in ("one", "two"))
    assert [x["conditions"] for x in one] == [x["conditions"] for x in two]  # drawn from the seed alone
    placed = [x["conditions"]["distractors"]["placed"] for x in one]
    assert all(len(p) == 2 for p in placed) and len({json.dumps(p) for p in placed}) == len(placed)
    for x, items in zip(one, placed, strict=True):  # never on the tube, wherever it was put
        start = x["conditions"]["object_pose"]
        for d in items:
            assert abs(d["x"] - (0.5 + start["dx"])) + abs(d["y"] - start["dy"]) > 0.1
