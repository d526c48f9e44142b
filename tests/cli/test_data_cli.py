"""``pipette data inspect | delete-episode | pack | replay`` on a recorded file, and on broken ones."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from pipette_cli.demos.collect import collect
from pipette_cli.demos.store import pack, part_path, parts_dir
from pipette_cli.registry import load_registry

pytestmark = pytest.mark.render
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "demos"
sys.path.insert(0, str(FIXTURES))
import demo_experts  # noqa: E402

REGISTRY = str(FIXTURES / "registry")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("data") / "rec.h5"
    task = load_registry([Path(REGISTRY)]).get("testlab/HoldTube-v1")
    collect(task, out, episodes=3, seed=0, image_size=16, expert_factory=demo_experts.Wiggle)
    return out


@pytest.fixture
def copy(recorded: Path, tmp_path: Path) -> Path:
    target = tmp_path / "copy.h5"
    shutil.copy(recorded, target)
    return target


def test_inspect_lists_episodes(run_cli, copy: Path) -> None:
    result = run_cli("data", "inspect", copy, "--json")
    assert result.exit_code == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["task_id"] == "testlab/HoldTube-v1" and report["image_size"] == [16, 16]
    assert report["num_episodes"] == 3 and report["pending"] == 0 and report["steps"] == 45
    assert [(e["index"], e["seed"], e["success"], e["reason"]) for e in report["episodes"]] == [
        (0, 0, False, "not_lifted"),
        (1, 1, False, "not_lifted"),
        (2, 2, False, "not_lifted"),
    ]
    text = run_cli("data", "inspect", copy)
    assert "testlab/HoldTube-v1" in text.stdout and "not_lifted" in text.stdout
    assert "3 episodes, 0 successful, 45 control steps" in text.stderr


def test_inspect_shows_pending_parts_and_pack_moves_them(run_cli, copy: Path, tmp_path: Path) -> None:
    parts_dir(copy).mkdir()
    with h5py.File(copy, "r") as src, h5py.File(part_path(copy, 3), "w") as part:
        part.attrs.update(dict(src.attrs))
        src.copy(src["episodes/episode_000002"], part.create_group("episodes"), name="episode_000003")
        part["episodes/episode_000003"].attrs["uid"] = "another-episode"
        part["episodes/episode_000003"].attrs["seed"] = 9
    report = json.loads(run_cli("data", "inspect", copy, "--json").stdout)
    assert report["num_episodes"] == 4 and report["pending"] == 1 and report["episodes"][3]["pending"]
    assert "pending" in run_cli("data", "inspect", copy).stderr
    assert run_cli("data", "delete-episode", copy, "0").exit_code == 1  # refused while parts are pending
    assert run_cli("data", "pack", copy).exit_code == 0
    report = json.loads(run_cli("data", "inspect", copy, "--json").stdout)
    assert report["pending"] == 0 and [e["seed"] for e in report["episodes"]] == [0, 1, 2, 9]
    assert not parts_dir(copy).exists()


def test_delete_episode(run_cli, copy: Path) -> None:
    result = run_cli("data", "delete-episode", copy, "1")
    assert result.exit_code == 0, result.stderr
    report = json.loads(run_cli("data", "inspect", copy, "--json").stdout)
    assert [(e["index"], e["seed"]) for e in report["episodes"]] == [(0, 0), (1, 2)]


def test_out_of_range_episode_is_a_clear_error_and_the_file_is_unchanged(run_cli, copy: Path) -> None:
    before = copy.read_bytes()
    for args in (("delete-episode", copy, "3"), ("replay", copy, "--episode", "3", "--check")):
        result = run_cli("data", *args)
        assert result.exit_code == 1, args
        assert (
            "episode" in result.stderr
            and "out of range" in result.stderr
            and "has 3 episodes (valid: 0..2)" in result.stderr
        )
    assert copy.read_bytes() == before


def test_replay_check_reproduces_the_episode(run_cli, copy: Path) -> None:
    result = run_cli("--registry-dir", REGISTRY, "data", "replay", copy, "--episode", "2", "--check")
    assert result.exit_code == 0, result.stderr
    assert "all 15 states bit-exact; same outcome" in result.stdout
    report = json.loads(
        run_cli("--registry-dir", REGISTRY, "data", "replay", copy, "-e", "0", "--check", "--json").stdout
    )
    assert report["ok"] and report["states_compared"] == 15 and report["recorded"] == report["replayed"]


def test_replay_check_fails_on_a_changed_state(run_cli, copy: Path) -> None:
    with h5py.File(copy, "r+") as f:
        states = f["episodes/episode_000001/sim_state"]
        row = states[10]
        row[1] = np.nextafter(row[1], np.inf)  # one ulp of the first qpos
        states[10] = row
    before = copy.read_bytes()
    result = run_cli("--registry-dir", REGISTRY, "data", "replay", copy, "--episode", "1", "--check")
    assert result.exit_code == 1
    assert "states differ from step 10 on" in result.stdout
    assert "episode 1 does not replay exactly" in result.stderr
    assert copy.read_bytes() == before


@pytest.mark.parametrize("damage", ["garbage", "truncated", "missing"])
def test_broken_files_are_refused_and_left_unchanged(run_cli, copy: Path, damage: str) -> None:
    if damage == "garbage":
        copy.write_bytes(b"\x89HDF\r\n" + bytes(range(256)) * 64)
        message = "is not a readable HDF5 file"
    elif damage == "truncated":
        copy.write_bytes(copy.read_bytes()[: copy.stat().st_size * 2 // 3])
        message = "is not a readable HDF5 file (truncated file"
    else:
        copy.unlink()
        message = "no such file"
    before = copy.read_bytes() if copy.exists() else None
    for args in (("inspect", copy), ("delete-episode", copy, "0"), ("replay", copy, "--check"), ("pack", copy)):
        result = run_cli("--registry-dir", REGISTRY, "data", *args)
        assert result.exit_code == 1, (args, result.stderr)
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], (args, result.stderr)
        assert (copy.read_bytes() if copy.exists() else None) == before


def test_a_file_that_is_not_a_pipette_file(run_cli, tmp_path: Path) -> None:
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["data"] = np.arange(3)
    result = run_cli("data", "inspect", other)
    assert result.exit_code == 1 and "is not a Pipette episode file" in result.stderr


def test_pack_of_a_file_without_parts_changes_nothing(copy: Path) -> None:
    before = copy.read_bytes()
    assert pack(copy) == 0 and copy.read_bytes() == before


def test_inspect_shows_the_arrays_and_an_augmented_episodes_variant(run_cli, copy: Path) -> None:
    with h5py.File(copy, "r+") as f:  # as `pipette augment` marks its episodes
        f["episodes/episode_000001"].attrs["augment_variant"] = "light+cam"
    report = json.loads(run_cli("data", "inspect", copy, "--json").stdout)
    assert [e["variant"] for e in report["episodes"]] == ["", "light+cam", ""]
    assert report["arrays"]["images/top"] == {"shape": [15, 16, 16, 3], "dtype": "uint8"}
    assert report["arrays"]["action"]["shape"][0] == 15 and "gripper 1 open, 0 closed" in report["action"]
    text = run_cli("data", "inspect", copy)
    assert "light+cam" in text.stdout and "variant" in text.stdout
    assert "arrays of episode 0: action (15," in text.stderr and "images/top (15, 16, 16, 3) uint8" in text.stderr
