"""``pipette convert`` and ``pipette data stats`` from the command line: results, exit codes, messages."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from pipette_cli.demos.collect import collect
from pipette_cli.registry import load_registry

pytestmark = pytest.mark.render
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "demos"
sys.path.insert(0, str(FIXTURES))
import demo_experts  # noqa: E402


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("convert_cli") / "rec.h5"
    task = load_registry([FIXTURES / "registry"]).get("testlab/HoldTube-v1")
    collect(task, out, episodes=2, seed=0, image_size=16, expert_factory=demo_experts.Wiggle)
    with h5py.File(out, "r+") as f:  # Wiggle never succeeds; mark episode 1 successful
        f["episodes/episode_000001"].attrs.update(success=True, failed=False, reason="")
    return out


def test_convert_then_stats(run_cli, recording: Path, tmp_path: Path) -> None:
    root = tmp_path / "tube" / "raw"
    result = run_cli("convert", recording, "--repo-id", "local/tube", "--root", root, "--images", "--json")
    assert result.exit_code == 0, result.stderr
    report = json.loads(result.stdout)
    assert (report["episodes"], report["frames"], report["skipped_failed"]) == (1, 5, 1) and report["frames_per_s"] > 0
    assert "convert: 1/1 episodes (100 %), " in result.stderr  # stderr is no terminal: lines, not a bar
    stats = run_cli("data", "stats", root, "--json")
    assert stats.exit_code == 0, stats.stderr
    data = json.loads(stats.stdout)
    assert (data["episodes"], data["frames"], data["fps"], data["video"]) == (1, 5, 10, False)
    assert data["provenance"]["successful"] == 1 and data["provenance"]["skipped_failed"] == 1
    assert data["features"]["observation.state"]["shape"] == [8] and len(data["features"]["action"]["min"]) == 8
    text = run_cli("data", "stats", root)
    assert (
        text.exit_code == 0
        and "1 episode, 5 frames at 10 Hz" in text.stdout
        and "1 successful, 0 failed" in text.stdout
    )
    action = data["features"]["action"]  # a vector: one named row per dimension, min, mean and max
    assert action["names"][0] == "joint1_target" and action["names"][-1] == "gripper_open"
    [row] = [line for line in text.stdout.splitlines() if "gripper_open" in line]
    cells = [c.strip() for c in row.strip("│ ").split("│")]
    assert cells == ["action", "7", "gripper_open", *(f"{action[k][7]:.3g}" for k in ("min", "mean", "max"))]
    assert "per dimension below" in text.stdout and "observation.images" not in text.stdout.split("dimensions")[-1]


def test_errors_are_one_line_and_leave_nothing(run_cli, recording: Path, tmp_path: Path) -> None:
    root = tmp_path / "ds"
    cases = [
        (["--images", "--fps", "7"], "does not divide"),
        (["--dataset-version", "augmented", "--images"], "--dataset-version raw"),
        (["--include-failed"], "too small for the libsvtav1 codec"),
        (["--images", "--repo-id", "bad"], "OWNER/NAME"),
    ]
    for extra, message in cases:
        args = ["convert", recording, "--root", root, *extra]
        if "--repo-id" not in extra:
            args += ["--repo-id", "local/x"]
        result = run_cli(*args)
        assert result.exit_code == 1, (extra, result.stderr)
        assert message in result.stderr and result.stderr.count("error:") == 1 and "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == []
    assert run_cli("data", "stats", tmp_path).exit_code == 1
    missing = run_cli("convert", tmp_path / "nope.h5", "--repo-id", "local/x", "--root", root)
    assert missing.exit_code == 1 and "no such file" in missing.stderr


def test_video_conversion_prints_no_encoder_logs(recording: Path, tmp_path: Path) -> None:
    """FFmpeg's and the encoders' info lines (x264's statistics, about 60 per episode) stay out of
    the terminal; only pipette's own progress is printed (a separate process: they are C-level)."""
    run = subprocess.run(
        [sys.executable, "-m", "pipette_cli.cli.main", "convert", str(recording), "--root", str(tmp_path / "v")]
        + ["--video", "--vcodec", "h264", "--include-failed"],
        capture_output=True,
        text=True,
        env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")},
    )
    assert run.returncode == 0, run.stderr
    assert "[libx264" not in run.stderr and "Svt[" not in run.stderr, run.stderr[:2000]
    assert run.stderr.strip().splitlines()[-1].startswith("convert: 2/2 episodes"), run.stderr
