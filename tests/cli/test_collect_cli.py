"""``pipette collect``: recording, resuming, and the refusals that leave a file untouched."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from pipette_cli.demos.experts import base as experts

pytestmark = pytest.mark.render
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "demos"
sys.path.insert(0, str(FIXTURES))
import demo_experts  # noqa: E402

REGISTRY = str(FIXTURES / "registry")
TASK = "testlab/HoldTube-v1"


@pytest.fixture
def wiggle(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(experts._CUSTOM, "testlab/HoldTube", demo_experts.Wiggle)


def _collect(run_cli, out: Path, *extra: str):
    return run_cli("--registry-dir", REGISTRY, "collect", TASK, "--out", out, "--image-size", "16", *extra)


def test_a_task_without_expert_is_one_clear_error(run_cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from pipette_cli.skills import derive

    monkeypatch.delitem(derive.DERIVERS._items, "lift_and_hold")  # no program in its YAML, none derivable
    out = tmp_path / "x.h5"
    result = _collect(run_cli, out, "--episodes", "1")
    assert result.exit_code == 1
    assert result.stderr.strip().startswith(
        "error: testlab/HoldTube-v1: no expert program can be read off a 'lift_and_hold' criterion"
    )
    assert "Traceback" not in result.stderr and not out.exists()


def test_a_generated_task_is_collected_with_its_family_expert(run_cli, tmp_path: Path) -> None:
    out = tmp_path / "g.h5"
    result = run_cli(
        "collect", "generated/PickUpConicalTube50mlSkirted-v1", "--out", out, "--episodes", "1", "--image-size", "16"
    )
    assert result.exit_code == 0, result.stderr
    assert "1 episode (1 new, 1 successful" in result.stdout
    report = json.loads(run_cli("data", "inspect", out, "--json").stdout)
    assert report["task_id"] == "generated/PickUpConicalTube50mlSkirted-v1"
    assert [e["success"] for e in report["episodes"]] == [True]


def test_collect_then_resume_to_more_episodes(run_cli, wiggle, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "x.h5"
    monkeypatch.setenv("PIPETTE_PROGRESS_INTERVAL", "0")  # a progress line at every episode
    first = _collect(run_cli, out, "--episodes", "2", "--seed", "3")
    assert first.exit_code == 0, first.stderr
    assert "2 episodes (2 new" in first.stdout
    lines = [x for x in first.stderr.splitlines() if x.startswith("collect ")]  # stderr is no terminal
    assert len(lines) == 2, first.stderr  # one per episode here; the final state is not repeated
    assert lines[0].startswith("collect HoldTube-v1: 1/2 episodes (50 %), ") and lines[0].endswith("; 0 ok 1 failed")
    assert lines[1].startswith("collect HoldTube-v1: 2/2 episodes (100 %), ") and "episodes/" in lines[1]
    again = _collect(run_cli, out, "--episodes", "3", "--seed", "3")
    assert again.exit_code == 0, again.stderr
    assert "2 episodes already recorded; 1 to go" in again.stderr and "3 episodes (1 new" in again.stdout
    done = _collect(run_cli, out, "--episodes", "3", "--seed", "3")
    assert "3 episodes, all recorded before (nothing new to collect)" in done.stdout
    report = json.loads(run_cli("data", "inspect", out, "--json").stdout)
    assert [e["seed"] for e in report["episodes"]] == [3, 4, 5]
    assert all(e["steps"] == 15 and e["source"] == "scripted" for e in report["episodes"])


def test_a_file_of_another_task_or_image_size_is_refused_untouched(run_cli, wiggle, tmp_path: Path) -> None:
    out = tmp_path / "x.h5"
    assert _collect(run_cli, out, "--episodes", "1").exit_code == 0
    before = out.read_bytes()
    other = run_cli("collect", "PickUpTestTube", "--out", out, "--episodes", "2", "--image-size", "16")
    assert other.exit_code == 1
    assert "holds episodes of task testlab/HoldTube-v1, not pipette/PickUpTestTube-v1" in other.stderr
    bigger = _collect(run_cli, out, "--episodes", "2", "--image-size", "32")
    assert bigger.exit_code == 1 and "has 16x16 images, not 32x32; pass --image-size 16" in bigger.stderr
    assert out.read_bytes() == before


def test_a_robot_that_cannot_do_the_task_is_refused_before_any_episode(run_cli, tmp_path: Path) -> None:
    """The Piper cannot reach the centrifuge lid's edge (0.61 m above its base): its expert stops
    naming that limit before moving, so collect refuses up front instead of recording failures."""
    out = tmp_path / "piper.h5"
    result = run_cli("collect", "CloseCentrifugeLid", "--robot", "piper", "--episodes", "2", "--out", out)
    said = " ".join(result.stderr.split())
    assert result.exit_code == 1 and not out.exists(), result.stderr
    assert "pipette/CloseCentrifugeLid-v1 on the agilex_piper: reach: the push on 'centrifuge/lid_hinge'" in said
    assert "(its expert, seeds 0-2)" in said


def test_robot_limit_is_found_only_where_every_seed_stops_at_one() -> None:
    from pipette_cli.demos.check import robot_limit
    from pipette_cli.demos.embodiment import on_robot
    from pipette_cli.registry import load_registry

    task = load_registry().get("pipette/CloseCentrifugeLid-v1")
    assert robot_limit(on_robot(task, "ur5e_robotiq"), seeds=(0,)) is None  # the UR5e closes it
    limit = robot_limit(on_robot(task, "agilex_piper"), seeds=(0, 1))
    assert limit is not None and limit.startswith("reach: ")


def test_teleop_needs_a_display_and_one_worker(run_cli, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    result = _collect(run_cli, tmp_path / "t.h5", "--source", "teleop", "--episodes", "1")
    assert result.exit_code == 1 and "needs a display" in result.stderr
    workers = _collect(run_cli, tmp_path / "t.h5", "--source", "teleop", "--workers", "2")
    assert workers.exit_code == 1 and "--workers applies to --source scripted only" in workers.stderr
    assert _collect(run_cli, tmp_path / "t.h5", "--source", "vr").exit_code == 2
    assert not (tmp_path / "t.h5").exists()
