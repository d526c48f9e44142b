"""`pipette convert` on real recordings: a fresh process loads the LeRobot dataset, values match the HDF5.

Recordings come from the collector (fixture task testlab/HoldTube-v1, Wiggle expert, 32 px,
15 control steps = 5 fresh frames per episode). Wiggle never lifts the tube, so episode 0 is
marked successful by editing its attributes (the verdict is not what is under test here).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import uuid
from pathlib import Path

import h5py
import numpy as np
import pytest

from pipette_cli.demos.collect import collect
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.errors import DatasetError
from pipette_cli.lerobot.convert import PROVENANCE_FILE, ConvertOptions, convert
from pipette_cli.lerobot.frames import FrameFilter
from pipette_cli.lerobot.stats import dataset_stats
from pipette_cli.registry import load_registry

pytestmark = pytest.mark.render
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "demos"
sys.path.insert(0, str(FIXTURES))
import demo_experts  # noqa: E402

CAMERAS = ("top", "main", "wrist")
PANDA_JOINTS = [f"joint{i}" for i in range(1, 8)]
LOADER = """
import sys, numpy as np
from lerobot.datasets.lerobot_dataset import LeRobotDataset
for repo_id, root, dump in zip(*[iter(sys.argv[1:])] * 3):
    ds = LeRobotDataset(repo_id, root=root, video_backend="pyav")
    items = [ds[i] for i in range(len(ds))]
    out = {"episodes": np.array(ds.num_episodes), "frames": np.array(ds.num_frames), "fps": np.array(ds.fps)}
    for key in ("observation.state", "action", "episode_index", "frame_index", "timestamp"):
        out[key] = np.stack([it[key].numpy() for it in items])
    for cam in ("top", "main", "wrist"):
        out[cam] = np.stack([(it["observation.images." + cam].permute(1, 2, 0).numpy() * 255).round() for it in items]).astype(np.uint8)
    out["task"] = np.array([it["task"] for it in items])
    np.savez(dump, **out)
"""


def set_attrs(path: Path, episode: int, **attrs: object) -> None:
    with h5py.File(path, "r+") as f:
        f[f"episodes/episode_{episode:06d}"].attrs.update(attrs)


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    """Two episodes, the first one marked successful."""
    out = tmp_path_factory.mktemp("convert") / "rec.h5"
    task = load_registry([FIXTURES / "registry"]).get("testlab/HoldTube-v1")
    collect(task, out, episodes=2, seed=0, image_size=32, expert_factory=demo_experts.Wiggle)
    set_attrs(out, 0, success=True, failed=False, reason="")
    return out


def renamed_copy(src: Path, dst: Path, **file_attrs: object) -> Path:
    """A copy whose episodes have new uids (a distinct recording), with changed file/episode attributes."""
    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        f.attrs.update(file_attrs)
        for group in f["episodes"].values():
            group.attrs["uid"] = uuid.uuid4().hex
            group.attrs.update({k: v for k, v in file_attrs.items() if k in ("task_id", "embodiment")})
    return dst


@pytest.fixture(scope="module")
def converted(recording: Path, tmp_path_factory) -> dict[str, object]:
    """The recording as an images dataset (both episodes) and a video dataset (the successful one),
    both loaded back by one fresh Python process."""
    base = tmp_path_factory.mktemp("datasets")
    results = {
        "images": convert(
            [recording],
            ConvertOptions(repo_id="local/tube_raw", root=base / "images", video=False, include_failed=True),
        ),
        "video": convert([recording], ConvertOptions(repo_id="local/tube_video", root=base / "video", video=True)),
    }
    args = [str(x) for kind, r in results.items() for x in (r.repo_id, r.root, base / f"{kind}.npz")]
    subprocess.run([sys.executable, "-c", LOADER, *args], check=True, capture_output=True)
    loaded = {}
    for kind in results:
        with np.load(base / f"{kind}.npz") as data:
            loaded[kind] = dict(data)
    return {"base": base, "results": results, "loaded": loaded}


def expected(path: Path, episodes: list[int]) -> dict[str, np.ndarray]:
    """The HDF5 values at the fresh steps of ``episodes``, concatenated."""
    status = scan(path)
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("state", "action", *CAMERAS)}
    for index in episodes:
        record = read_episode(status.episode(index), images=True)
        keep = np.flatnonzero(record.arrays["fresh"])
        assert keep.tolist() == [0, 3, 6, 9, 12]
        parts["state"].append(record.arrays["state"][keep])
        parts["action"].append(record.arrays["action"][keep])
        for cam in CAMERAS:
            parts[cam].append(record.images[cam][keep])
    return {k: np.concatenate(v) for k, v in parts.items()}


def test_images_dataset_loads_in_a_fresh_process_with_exact_values(recording: Path, converted) -> None:
    result, loaded = converted["results"]["images"], converted["loaded"]["images"]
    assert (result.episodes, result.frames) == (2, 10)
    want = expected(recording, [0, 1])
    assert int(loaded["episodes"]) == 2 and int(loaded["frames"]) == 10 and int(loaded["fps"]) == 10
    assert (
        loaded["episode_index"].tolist() == [0] * 5 + [1] * 5 and loaded["frame_index"].tolist() == [0, 1, 2, 3, 4] * 2
    )
    np.testing.assert_allclose(loaded["timestamp"], np.tile(np.arange(5) / 10, 2), atol=1e-6)
    np.testing.assert_array_equal(loaded["observation.state"], want["state"])
    np.testing.assert_array_equal(loaded["action"], want["action"].astype(np.float32))
    for cam in CAMERAS:
        np.testing.assert_array_equal(loaded[cam], want[cam])
    assert set(loaded["task"]) == {"Hold still next to the test tube."}
    assert sorted(p.name for p in converted["base"].iterdir() if p.is_dir()) == [
        "images",
        "video",
    ]  # no temporary folder left


def test_video_dataset_matches_within_codec_tolerance(recording: Path, converted) -> None:
    result, loaded = converted["results"]["video"], converted["loaded"]["video"]
    root = result.root
    assert (result.episodes, result.frames, result.skipped) == (1, 5, 1)  # only the successful episode
    assert sorted(p.name for p in (root / "videos").iterdir()) == [f"observation.images.{c}" for c in sorted(CAMERAS)]
    want = expected(recording, [0])
    np.testing.assert_array_equal(loaded["observation.state"], want["state"])
    np.testing.assert_array_equal(loaded["action"], want["action"].astype(np.float32))
    for cam in CAMERAS:
        assert loaded[cam].shape == want[cam].shape
        error = np.abs(loaded[cam].astype(int) - want[cam].astype(int))
        assert error.mean() < 6.0, (cam, error.mean())  # AV1 at CRF 30 on 32x32 frames
        other = np.roll(want[cam], 1, axis=0)  # a different frame is further away than the codec error
        assert np.abs(loaded[cam].astype(int) - other.astype(int)).mean() > error.mean()


def test_stride_filter_and_provenance(recording: Path, tmp_path: Path) -> None:
    root = tmp_path / "ds"
    options = ConvertOptions(
        repo_id="local/s", root=root, video=False, fps=15, frame_filter=FrameFilter.stride, include_failed=True
    )
    result = convert([recording], options)
    assert result.frames == 16  # steps 0, 2, ..., 14 of two 15-step episodes
    provenance = json.loads((root / PROVENANCE_FILE).read_text())
    first = provenance["episodes"][0]
    assert (
        first["steps"] == list(range(0, 15, 2)) and first["stale_frames"] == 5
    )  # steps 2, 4, 8, 10, 14 repeat a frame
    assert [e["success"] for e in provenance["episodes"]] == [True, False] and provenance["episodes"][1][
        "reason"
    ] == "not_lifted"
    assert [e["seed"] for e in provenance["episodes"]] == [0, 1] and provenance["dataset_version"] == "raw"
    report = dataset_stats(root)
    assert (report["episodes"], report["frames"], report["fps"]) == (2, 16, 15)
    assert report["provenance"]["successful"] == 1 and report["provenance"]["failure_reasons"] == {"not_lifted": 1}
    state = scan(recording)
    rows = np.concatenate([read_episode(state.episode(i)).arrays["action"][::2] for i in (0, 1)]).astype(np.float32)
    np.testing.assert_allclose(report["features"]["action"]["min"], rows.min(axis=0), atol=1e-6)
    np.testing.assert_allclose(report["features"]["action"]["max"], rows.max(axis=0), atol=1e-6)


def test_raw_and_augmented_episodes_go_to_separate_datasets(recording: Path, tmp_path: Path) -> None:
    augmented = renamed_copy(recording, tmp_path / "aug.h5")
    set_attrs(augmented, 0, perturbation='{"lighting": 0.3}')
    set_attrs(augmented, 1, perturbation='{"lighting": 0.5}')
    with pytest.raises(DatasetError, match="--dataset-version augmented"):
        convert([recording, augmented], ConvertOptions(repo_id="local/r", root=tmp_path / "raw", video=False))
    assert not (tmp_path / "raw").exists()
    from pipette_cli.lerobot.convert import DatasetVersion

    root = tmp_path / "aug"
    convert(
        [augmented], ConvertOptions(repo_id="local/a", root=root, video=False, dataset_version=DatasetVersion.augmented)
    )
    report = dataset_stats(root)
    assert report["provenance"]["dataset_version"] == "augmented" and report["provenance"]["perturbed"] == 1
    with pytest.raises(DatasetError, match="--dataset-version raw"):
        convert(
            [recording],
            ConvertOptions(repo_id="local/a", root=tmp_path / "a2", dataset_version=DatasetVersion.augmented),
        )
    # a raw dataset already there: the augmented file's version is the error that names the fix, not the folder
    (tmp_path / "taken").mkdir()
    with pytest.raises(DatasetError, match=r"is augmented but this is a raw dataset.*--dataset-version augmented"):
        convert([augmented], ConvertOptions(repo_id="local/r", root=tmp_path / "taken", video=False))
    with pytest.raises(DatasetError, match="already exists; pass --overwrite"):
        convert([recording], ConvertOptions(repo_id="local/r", root=tmp_path / "taken", video=False))
    (tmp_path / "taken" / "precious.txt").write_text("keep me")
    with pytest.raises(DatasetError, match="not a LeRobot dataset"):
        convert([recording], ConvertOptions(repo_id="local/r", root=tmp_path / "taken", video=False, overwrite=True))
    assert (tmp_path / "taken" / "precious.txt").read_text() == "keep me"


def test_stats_count_unperturbed_originals_apart_from_perturbed_variants(recording: Path, tmp_path: Path) -> None:
    """``--variants original`` re-renders a demo unchanged: not a perturbed episode (issue 36: the
    20 originals of a paper,original run were counted among "60 perturbed")."""
    from pipette_cli.lerobot.convert import DatasetVersion

    augmented = renamed_copy(recording, tmp_path / "aug.h5")
    set_attrs(augmented, 0, augment_variant="original", augment_params="{}")
    params = '{"lighting": {"scale": 0.8}}'
    set_attrs(augmented, 1, success=True, failed=False, reason="", augment_variant="light", augment_params=params)
    root = tmp_path / "aug"
    convert(
        [augmented], ConvertOptions(repo_id="local/a", root=root, video=False, dataset_version=DatasetVersion.augmented)
    )
    provenance = dataset_stats(root)["provenance"]
    assert (provenance["perturbed"], provenance["originals"]) == (1, 1)


def test_bad_inputs_leave_nothing_behind(recording: Path, tmp_path: Path) -> None:
    other_task = renamed_copy(recording, tmp_path / "other.h5", task_id="testlab/Other-v1")
    root = tmp_path / "ds"
    with pytest.raises(DatasetError, match="--allow-mixed"):
        convert([recording, other_task], ConvertOptions(repo_id="local/m", root=root, video=False))
    other_robot = renamed_copy(recording, tmp_path / "robot.h5", embodiment="ur5e_robotiq")
    with pytest.raises(DatasetError, match="2 robots .*--allow-mixed-robots"):
        convert([recording, other_robot], ConvertOptions(repo_id="local/m", root=root, video=False))
    with pytest.raises(DatasetError, match="--allow-mixed-robots"):  # mixing tasks does not allow mixing robots
        convert([recording, other_robot], ConvertOptions(repo_id="local/m", root=root, video=False, allow_mixed=True))
    with pytest.raises(DatasetError, match="already in"):
        convert([recording, recording], ConvertOptions(repo_id="local/m", root=root, video=False))
    small = renamed_copy(recording, tmp_path / "small.h5", image_height=16)
    with pytest.raises(DatasetError, match="one image size"):
        convert([recording, small], ConvertOptions(repo_id="local/m", root=root, video=False))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other.h5", "robot.h5", "small.h5"]
    mixed = convert(
        [recording, other_task], ConvertOptions(repo_id="local/m", root=root, video=False, allow_mixed=True)
    )
    assert mixed.episodes == 2 and dataset_stats(root)["provenance"]["task_ids"] == [
        "testlab/HoldTube-v1",
        "testlab/Other-v1",
    ]
    features = json.loads((root / "meta" / "info.json").read_text())["features"]
    assert features["observation.state"]["names"] == [*PANDA_JOINTS, "gripper"]  # one robot: its joints
    assert features["action"]["names"] == [f"{j}_target" for j in PANDA_JOINTS] + ["gripper_open"]
    both = tmp_path / "both"
    convert(
        [recording, other_robot], ConvertOptions(repo_id="local/r", root=both, video=False, allow_mixed_robots=True)
    )
    info = json.loads((both / "meta" / "info.json").read_text())
    assert info["robot_type"] == "franka_panda,ur5e_robotiq"
    assert info["features"]["observation.state"]["names"][:2] == ["joint_1", "joint_2"]  # robots mixed: by position


def test_existing_dataset_needs_overwrite_and_a_failed_write_keeps_the_old_one(
    recording: Path, tmp_path: Path, monkeypatch
) -> None:
    root = tmp_path / "ds"
    convert([recording], ConvertOptions(repo_id="local/o", root=root, video=False))
    with pytest.raises(DatasetError, match="--overwrite"):
        convert([recording], ConvertOptions(repo_id="local/o", root=root, video=False, include_failed=True))
    import pipette_cli.lerobot.convert as module

    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(module, "_read_images", broken)
    with pytest.raises(DatasetError, match="disk full"):
        convert(
            [recording], ConvertOptions(repo_id="local/o", root=root, video=False, include_failed=True, overwrite=True)
        )
    assert dataset_stats(root)["episodes"] == 1  # the old dataset is intact
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]  # the partial one is gone
    monkeypatch.undo()
    convert([recording], ConvertOptions(repo_id="local/o", root=root, video=False, include_failed=True, overwrite=True))
    assert dataset_stats(root)["episodes"] == 2
