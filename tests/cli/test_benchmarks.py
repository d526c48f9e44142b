"""The benchmark scripts run end to end at a tiny size and write JSON with the git commit.

Their numbers are not checked here (timing targets live in benchmarks/); what is checked is that
each script still works against the current code and reports what it claims to measure.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def bench(script: str, *args: str, timeout: float = 600) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / script), *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=ROOT,
        env={**os.environ, "HF_HUB_OFFLINE": "1"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return result


def read(path: Path) -> dict:
    data = json.loads(path.read_text())
    commit = data.get("git_sha") or data["settings"]["git_commit"]
    assert len(commit) == 40 or commit == "unknown"
    return data


@pytest.mark.render
def test_bench_sim_reports_real_time_factor_per_task(tmp_path) -> None:
    out = tmp_path / "sim.json"
    result = bench("bench_sim.py", "--tasks", "PickUpTestTube,OpenCentrifugeLid", "--episodes", "1", "--out", str(out))
    rows = read(out)["results"]
    assert [r["task"] for r in rows] == ["pipette/PickUpTestTube-v1", "pipette/OpenCentrifugeLid-v1"]
    for r in rows:
        assert r["successes"] == 1 and r["control_steps"] > 30  # the expert really ran to success
        assert r["real_time_factor"] == pytest.approx(r["simulated_s"] / r["step_wall_s"], rel=0.02)
        assert r["real_time_factor"] > r["real_time_factor_with_expert"] > 0
    assert "PickUpTestTube" in result.stdout and "RTF" in result.stdout


@pytest.mark.render
def test_bench_render_covers_every_profile_and_size(tmp_path) -> None:
    out, png = tmp_path / "render.json", tmp_path / "profiles.png"
    bench(
        "bench_render.py",
        "--sizes",
        "32,48",
        "--frames",
        "2",
        "--rounds",
        "1",
        "--out",
        str(out),
        "--picture",
        str(png),
    )
    data = read(out)
    rows = data["results"]
    profiles = ("fast", "full", "fast-original-meshes")
    assert {(r["profile"], r["size"]) for r in rows} == {(p, s) for p in profiles for s in (32, 48)}
    assert all(r["captures_per_s"] > 0 and r["frames"] == 2 for r in rows)
    triangles = {r["profile"]: r["triangles"] for r in rows}
    assert triangles["fast"] * 4 < triangles["full"] == triangles["fast-original-meshes"]  # fast: decimated meshes
    assert len(data["loadavg_before"]) == 3
    from PIL import Image

    assert Image.open(png).size == (3 * 48, 2 * 48)  # three views, fast above full


@pytest.mark.render
def test_bench_augment_compares_pipelines_floor_and_workers(tmp_path) -> None:
    out = tmp_path / "augment.json"
    result = bench(
        "bench_augment.py",
        "--demos",
        "1",
        "--variants",
        "light,speed",
        "--image-size",
        "32",
        "--repeats",
        "1",
        "--workers",
        "1,2",
        "--reference",
        str(ROOT),
        "--out",
        str(out),
    )
    data = read(out)
    runs, summary = data["runs"], data["summary"]
    for name in ("baseline", "ours", "reference", "floor"):
        assert runs[name][0]["kept"] == 2 and len(runs[name][0]["loadavg_before"]) == 3, name
    assert runs["floor"][0]["seconds"] == pytest.approx(runs["floor"][0]["physics_s"] + runs["floor"][0]["render_s"])
    assert summary["ours_over_floor"] == pytest.approx(runs["ours"][0]["seconds"] / runs["floor"][0]["seconds"])
    assert summary["ours_over_baseline"] == pytest.approx(
        runs["ours"][0]["kept_per_hour"] / runs["baseline"][0]["kept_per_hour"]
    )
    assert runs["reference"][0]["package"] == str(ROOT / "pipette_cli" / "__init__.py")  # the tree asked for
    assert [(r["executor"], r["workers"]) for r in data["scaling"]] == [("local", 1), ("local", 2)]
    assert data["scaling"][0]["efficiency"] == pytest.approx(1.0)
    assert "ours / baseline" in result.stdout and data["machine"]["cpus"] >= 1


@pytest.mark.render
def test_reproduce_table_runs_both_versions_and_resumes(tmp_path) -> None:
    work, docs = tmp_path / "work", tmp_path / "docs"
    args = (
        "--suite",
        "testlab/ReproSmoke-v1",
        "--registry-dir",
        str(ROOT / "tests" / "fixtures" / "reproduce"),
        "--demos",
        "2",
        "--steps",
        "2",
        "--batch-size",
        "2",
        "--variants",
        "original,light",
        "--workers",
        "1",
        "--tasks",
        "pipette/PickUpTestTube-v1",
        "--work",
        str(work),
        "--docs",
        str(docs),
    )
    bench("reproduce_table.py", *args)
    data = read(docs / "results.json")
    [row] = data["results"]
    assert row["demos"] == 2 and row["augment_tried"] == 4
    assert row["versions"]["raw"]["episodes"] == 2
    assert row["versions"]["augmented"]["episodes"] == row["augment_kept"]  # originals re-rendered + light
    assert {v["eval_episodes"] for v in row["versions"].values()} == {1}
    assert {v["suite"]["id"] for v in row["versions"].values()} == {"testlab/ReproSmoke-v1"}
    assert row["comparison"]["test"] == "mcnemar_exact"  # the same suite episodes on both sides: paired
    table = (docs / "table.md").read_text()
    assert "pipette/PickUpTestTube-v1" in table and "100 -> 100" in table  # the paper's ACT numbers beside ours
    assert "0/1 (0 %, 0-79)" in table  # an interval with every cell
    assert data["pending"] == ["pipette/CloseCentrifugeLid-v1"]  # a partial run says what it leaves out
    assert "Not in this table: pipette/CloseCentrifugeLid-v1 (of suite testlab/ReproSmoke-v1)" in table
    assert (docs / "success.png").stat().st_size > 0
    checkpoints = sorted(work.rglob("checkpoints/last/pretrained_model/config.json"))
    assert len(checkpoints) == 2
    stamp = [p.stat().st_mtime for p in checkpoints]
    rerun = bench("reproduce_table.py", *args, timeout=120)  # every stage is reused, nothing retrains
    assert [p.stat().st_mtime for p in checkpoints] == stamp
    assert "training ACT" not in rerun.stdout
    assert json.loads((docs / "results.json").read_text())["results"][0]["versions"] == row["versions"]


@pytest.mark.render
def test_bench_eval_measures_episodes_per_hour_and_dead_server_detection(tmp_path) -> None:
    out = tmp_path / "eval.json"
    result = bench(
        "bench_eval.py",
        "--task",
        "PickUpTestTube",
        "--image-size",
        "24",
        "--episodes",
        "1",
        "--workers",
        "1",
        "--strike-after",
        "1",
        "--out",
        str(out),
    )  # worker counts > 1: tests/sim/test_eval_runs.py
    data = read(out)
    assert [r["workers"] for r in data["results"]] == [1]
    for r in data["results"]:
        assert r["episodes"] == 1 and r["episodes_per_hour"] == pytest.approx(3600 / r["wall_s"], rel=0.01)
    dead = {d["server"]: d for d in data["dead_server"]}
    assert set(dead) == {"killed", "stopped"}
    assert (
        4 <= dead["killed"]["to_safe_hold_s"] < 10 and dead["stopped"]["to_safe_hold_s"] < 15
    )  # 5 s default (+3 s heartbeats)
    assert "episodes/h" in result.stdout


def test_bench_language_scores_both_development_sets(tmp_path) -> None:
    out = tmp_path / "language.json"
    result = bench("bench_language.py", "--limit", "4", "--out", str(out))
    data = read(out)
    assert data["agent"]["requests"] == 4 and data["new_task"]["sentences"] == 4
    assert data["agent"]["tracebacks"] == 0 and data["new_task"]["tracebacks"] == 0
    assert "pipette agent" in result.stdout and "pipette new-task" in result.stdout


def test_bench_robots_fills_the_task_by_robot_table(tmp_path) -> None:
    out, md = tmp_path / "robots.json", tmp_path / "robots.md"
    result = bench(
        "bench_robots.py",
        "--tasks",
        "PickUpTestTube",
        "--robots",
        "piper,ur5e_2f85",
        "--episodes",
        "1",
        "--out",
        str(out),
        "--markdown",
        str(md),
    )
    data = read(out)
    cells = {c["robot"]: c for c in data["cells"]}
    assert set(cells) == {"agilex_piper", "ur5e_robotiq"} and data["robots"] == ["agilex_piper", "ur5e_robotiq"]
    assert cells["agilex_piper"]["successes"] == 1 and cells["agilex_piper"]["base"][0] > 0  # placed, then picked
    assert "| pipette/PickUpTestTube-v1 | 1/1 | 1/1 |" in md.read_text()
    assert "agilex_piper" in result.stdout


def test_bench_robots_shows_a_limit_every_seed_ran_into_as_a_refusal() -> None:
    import importlib.util

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_robots.py"
    spec = importlib.util.spec_from_file_location("bench_robots", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    why = "step 1 (close_hinge lid): reach: the push on 'lid' starts 0.61 m above the base; no hand pose reaches it"
    assert module.LIMIT.search(why).group(1).startswith("reach: the push")
    assert module.LIMIT.search("step 2 (pick dish): the grasp on 'dish' did not hold") is None
    row = {"task": "t", "robot": "r", "refused": "t on the r: reach: the push ...", "episodes": 3}
    assert module.cell_text(row) == "refused (reach)"
    assert "found by the expert on all 3 seeds" in module.markdown([row], ["t"], ["r"], 3, 0, "abc")


@pytest.mark.slow
@pytest.mark.render
def test_augmentation_experiment_runs_every_stage_at_a_tiny_size_and_resumes(tmp_path) -> None:
    """About 8 minutes: a pilot, six data settings trained and evaluated on the three suites, the report."""
    work, docs = tmp_path / "work", tmp_path / "docs"
    tiny = ("--work", str(work), "--docs", str(docs), "--tasks", "pipette/PickUpTestTube-v1", "--demos", "2")
    bench("augmentation_experiment.py", "pilot", *tiny, "--pilot-steps", "1,4", "--pilot-episodes", "2")
    pilot = json.loads((docs / "pilot.json").read_text())
    assert set(pilot["success"]["pipette/PickUpTestTube-v1"]) == {"1", "4"} and pilot["seeds"] == [1000, 1001]
    run = (*tiny, "--pilot-steps", "1,4", "--steps", "4", "--max-episodes", "2")
    bench("augmentation_experiment.py", "run", *run, timeout=1200)
    data = read(docs / "results.json")
    for suite in ("nominal", "shifted"):
        cells = data["suites"][suite]["cells"]
        assert {k.split()[1] for k in cells} == {"raw", "aug_all", "aug_object", "aug_visual", "more_demos"}
        assert all(c["episodes"] == 2 for c in cells.values())
        assert {r["family"] for r in data["suites"][suite]["comparisons"]} == {"primary", "secondary"}
    clutter = data["suites"]["clutter"]  # amendment 1: raw, aug_all and aug_clutter among distractors
    assert {k.split()[1] for k in clutter["cells"]} == {"raw", "aug_all", "aug_clutter"}
    assert {r["family"] for r in clutter["comparisons"]} == {"amendment 1"}
    kept = data["yield"]["pipette/PickUpTestTube-v1"]["aug_all"]["kept"]
    logs = list((work / "pipette_PickUpTestTube-v1" / "eval" / "shifted" / "raw").glob("episode_*.json"))
    assert logs and all(json.loads(p.read_text())["conditions"]["object_pose"]["task_range"] == 1.5 for p in logs)
    checkpoints = sorted(work.rglob("checkpoints/last/pretrained_model/config.json"))
    assert len(checkpoints) == 6 and kept >= 2  # raw is the pilot's run (its checkpoints at 1, 2 and 4 steps)
    assert (work / "pipette_PickUpTestTube-v1" / "eval" / "curve" / "raw@1").is_dir()
    stamp = [p.stat().st_mtime for p in checkpoints]
    again = bench("augmentation_experiment.py", "run", *run, timeout=600)  # every stage reused
    assert "training" not in again.stdout and [p.stat().st_mtime for p in checkpoints] == stamp


@pytest.mark.render
def test_bench_train_times_lerobot_train_steps_of_each_config(tmp_path) -> None:
    out = tmp_path / "train.json"
    result = bench(
        "bench_train.py",
        *("--work", str(tmp_path / "work"), "--episodes", "1", "--configs", "before,after"),
        *("--steps", "4", "--warmup", "1", "--rounds", "1", "--out", str(out)),
    )
    data = read(out)
    assert list(data["rows"]) == ["before", "after"]
    for row in data["rows"].values():
        [step] = row["s_per_step_rounds"]
        assert row["s_per_step"] == step and row["samples_per_s"] == pytest.approx(8 / step)
        assert 0 < row["data_s"] < step and 0 < row["update_s"] < step
    [before], [after] = data["runs"]["before"], data["runs"]["after"]
    assert [a for a in before["argv"] if a.startswith("--num_workers")][-1] == "--num_workers=0"
    assert "OMP_NUM_THREADS" not in before["env"]  # the preset as it was: data in-process, torch's threads
    assert [a for a in after["argv"] if a.startswith("--num_workers")][-1] == "--num_workers=1"
    assert after["env"]["OMP_NUM_THREADS"] == "1"
    assert "--log_freq=1" in after["argv"] and "| before |" in result.stdout


def test_placement_misses_counts_episodes_ending_near_the_target_and_why_they_failed(tmp_path) -> None:
    cell = tmp_path / "pipette_PlaceTubeOnBalance-v1" / "eval" / "nominal" / "raw"
    cell.mkdir(parents=True)
    ends = [(True, None, 0.01), (False, "out_of_region", 0.04), (False, "held", 0.02), (False, "out_of_region", 0.4)]
    for i, (success, reason, error) in enumerate(ends):
        log = {"success": success, "failure_reason": reason, "metrics": {"xy_error": error}}
        (cell / f"episode_{i:04d}.json").write_text(json.dumps(log))
    args = ("--keep", str(tmp_path), "--task", "pipette/PlaceTubeOnBalance-v1", "--near", "0.1", "--json")
    [row] = json.loads(bench("placement_misses.py", *args).stdout)
    assert (row["suite"], row["setting"], row["successes"], row["near"]) == ("nominal", "raw", 1, 3)
    assert row["near_failed"] == {"held": 1, "out_of_region": 1}  # the one 0.4 m away is no near miss
