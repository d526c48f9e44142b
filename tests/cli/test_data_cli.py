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


def test_video_writes_an_episode_as_a_real_time_gif_of_its_views(run_cli, copy: Path, tmp_path: Path) -> None:
    from PIL import Image

    from pipette_cli.demos.store import read_episode, scan
    from pipette_cli.demos.video import episode_frames

    result = run_cli("data", "video", copy, "--episode", "1", "--out", tmp_path / "ep1.gif")
    assert result.exit_code == 0, result.stderr
    assert f"episode 1 (seed 1, failed (not_lifted)) -> {tmp_path / 'ep1.gif'}" in result.stdout
    status = scan(copy)
    # 15 control steps at 30 Hz, one frame every 3 and the last: 0, 3, 6, 9, 12, 14; 100 ms each
    assert len(episode_frames(status, 1)) == 6
    with Image.open(tmp_path / "ep1.gif") as gif:
        durations = []
        for k in range(gif.n_frames):  # PIL merges identical neighbours into one longer frame
            gif.seek(k)
            durations.append(gif.info["duration"])
        assert sum(durations) == 600 and gif.n_frames >= 2
        assert gif.size == (3 * 16 * 8 + 2 * 4, 16 * 8)  # three 16 px views enlarged to 128, 4 px apart
    assert list(read_episode(status.episode(1), images=["main"]).images) == ["main"]  # only what is shown is read
    recorded = read_episode(status.episode(1), images=True).images["main"]
    frames = episode_frames(status, 1, cameras=["main"], fps=30, scale=1)
    assert len(frames) == len(recorded) == 15
    for frame, image in zip(frames, recorded, strict=True):  # below the label, the recorded pixels
        assert np.array_equal(frame[10:], image[10:])


def test_video_of_every_episode_into_a_folder_as_mp4(run_cli, copy: Path, tmp_path: Path) -> None:
    import av

    result = run_cli("data", "video", copy, "--all", "--format", "mp4", "--camera", "wrist", "--out", tmp_path)
    assert result.exit_code == 0, result.stderr
    written = sorted(tmp_path.glob("*.mp4"))
    assert [p.name for p in written] == [f"copy_episode_{i:04d}.mp4" for i in range(3)]
    with av.open(str(written[0])) as container:
        frames = list(container.decode(video=0))
    assert len(frames) == 6 and (frames[0].width, frames[0].height) == (128, 128)


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--all", "--out", "one.gif"], "one file for 3 episodes; give a folder instead"),
        (["--camera", "side"], "no camera side (recorded: top, main, wrist)"),
        (["--fps", "60"], "between 0 and the recording's control rate (30 Hz)"),
        (["--out", "ep.avi"], "cannot write a .avi animation (use .gif or .mp4)"),
        (["--episode", "0", "--episode", "7"], "episode 7 is out of range"),
    ],
)
def test_video_refuses_what_it_cannot_write_and_writes_nothing(
    run_cli, copy: Path, tmp_path: Path, monkeypatch, args: list[str], said: str
) -> None:
    monkeypatch.chdir(tmp_path)
    result = run_cli("data", "video", copy, *args)
    assert result.exit_code == 1 and said in result.stderr, result.stderr
    assert not [p for p in tmp_path.iterdir() if p.suffix in (".gif", ".mp4", ".avi")]


def test_video_formats_are_the_two_it_writes(run_cli, copy: Path, tmp_path: Path) -> None:
    result = run_cli("data", "video", copy, "--format", "webm", "--out", tmp_path)
    assert result.exit_code == 2 and "'webm' is not one of 'gif', 'mp4'" in result.stderr, result.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["copy.h5"]
