"""The HDF5 recorder and its file store on synthetic episodes (no simulation).

Covers the layout (dtypes, chunking, compression, stale frames), atomic packing of parts,
stale parts after a crash, deletion, and the clear errors on unreadable or foreign files
that leave the file's bytes unchanged.
"""

from __future__ import annotations

import os

import h5py
import numpy as np
import pytest

from pipette_cli.demos.collect import plan_seeds
from pipette_cli.demos.recorder import DatasetInfo, EpisodeWriter
from pipette_cli.demos.store import (
    delete_episode,
    lock_path,
    pack,
    part_path,
    parts_dir,
    read_episode,
    scan,
    writing,
)
from pipette_cli.errors import DatasetError
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.env import Observation

H = W = 8
INFO = DatasetInfo(
    task_id="testlab/Synthetic-v1",
    embodiment="franka_panda",
    instruction="do it",
    image_height=H,
    image_width=W,
    cameras=("top", "main", "wrist"),
    physics_hz=600,
    control_hz=30,
    vision_hz=10,
    state_dim=8,
    action_dim=8,
    sim_state_size=5,
)


def _observations(steps: int, rng: np.random.Generator) -> list[Observation]:
    """Observations following the 10 Hz vision schedule: stale steps reuse the same arrays."""
    out, images = [], {}
    for k in range(1, steps + 1):
        fresh = (k - 1) % 3 == 0
        if fresh:
            images = {c: rng.integers(0, 255, (H, W, 3), dtype=np.uint8) for c in INFO.cameras}
        out.append(
            Observation(
                dict(images),
                rng.normal(size=8).astype(np.float32),
                fresh,
                (k - 1) % 3,
                (k - 1) / 30,
                0.01 * k,
                k,
                "do it",
            )
        )
    return out


def write_episode(path, index: int, seed: int, steps: int = 7, info: DatasetInfo = INFO, success: bool = True) -> dict:
    """Write one closed and committed episode file; returns what went in."""
    rng = np.random.default_rng(seed)
    observations = _observations(steps, rng)
    actions = rng.normal(size=(steps, 8))
    states = rng.normal(size=(steps, info.sim_state_size))
    writer = EpisodeWriter(path, info, index=index, seed=seed, source="scripted", attrs={"git_commit": "abc"})
    for obs, action, state in zip(observations, actions, states):
        writer.add(obs, action, state)
    verdict = Verdict(success=success, failed=not success, reason=None if success else "dropped", metrics={"lift": 0.5})
    writer.close(verdict, np.zeros(8), np.ones(info.sim_state_size))
    writer.commit()
    return {"observations": observations, "actions": actions, "states": states, "uid": writer.uid}


def test_episode_layout_round_trips(tmp_path) -> None:
    path = tmp_path / "one.h5"
    written = write_episode(path, 0, seed=3)
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == "pipette.episodes" and f.attrs["task_id"] == INFO.task_id
        g = f["episodes/episode_000000"]
        top = g["images/top"]
        assert top.shape == (7, H, W, 3) and top.dtype == np.uint8
        assert top.chunks == (1, H, W, 3) and top.compression == "gzip" and top.compression_opts == 4
        assert g["action"].dtype == np.float64 and g["state"].dtype == np.float32
        assert g.attrs["seed"] == 3 and g.attrs["success"] and g.attrs["git_commit"] == "abc"
        assert g["instruction"].asstr()[0] == "do it"
    record = read_episode(scan(path).episode(0), images=True)
    for k, obs in enumerate(written["observations"]):
        for camera in INFO.cameras:
            np.testing.assert_array_equal(record.images[camera][k], obs.images[camera])
    assert record.images["top"][1].tobytes() == record.images["top"][0].tobytes()  # stale frame repeated
    np.testing.assert_array_equal(record.arrays["action"], written["actions"])  # float64, exact
    np.testing.assert_array_equal(record.arrays["sim_state"], written["states"])
    assert record.arrays["fresh"].tolist() == [True, False, False, True, False, False, True]
    assert record.arrays["frame_age"].tolist() == [0, 1, 2, 0, 1, 2, 0]


def test_aborted_writer_leaves_nothing(tmp_path) -> None:
    path = tmp_path / "x.h5"
    with EpisodeWriter(path, INFO, index=0, seed=0, source="scripted") as writer:
        writer.add(_observations(1, np.random.default_rng(0))[0], np.zeros(8), np.zeros(5))
    assert list(tmp_path.iterdir()) == []


def test_executed_actions_are_given_for_every_step_or_none(tmp_path) -> None:
    obs = _observations(3, np.random.default_rng(0))
    state = np.zeros(4)
    with EpisodeWriter(tmp_path / "a.h5", INFO, index=0, seed=0, source="augmented") as writer:
        writer.add(obs[0], np.zeros(8), state, executed=np.ones(8))
        with pytest.raises(DatasetError, match="every step of an episode or none"):
            writer.add(obs[1], np.zeros(8), state)
    with EpisodeWriter(tmp_path / "b.h5", INFO, index=0, seed=0, source="augmented") as writer:
        writer.add(obs[0], np.zeros(8), state)
        with pytest.raises(DatasetError, match="every step of an episode or none"):
            writer.add(obs[1], np.zeros(8), state, executed=np.ones(8))
    assert not list(tmp_path.iterdir())  # aborted: nothing written


def test_pack_appends_parts_in_order_and_removes_them(tmp_path) -> None:
    out = tmp_path / "data.h5"
    write_episode(part_path(out, 0), 0, seed=10)
    write_episode(part_path(out, 1), 1, seed=11)
    assert pack(out) == 2 and not parts_dir(out).exists()
    write_episode(part_path(out, 2), 2, seed=12, success=False)
    status = scan(out)
    assert [(r.summary.seed, r.pending) for r in status.episodes] == [(10, False), (11, False), (12, True)]
    assert pack(out) == 1
    status = scan(out)
    assert [r.summary.seed for r in status.packed] == [10, 11, 12] and not status.pending
    assert [r.summary.reason for r in status.packed] == ["", "", "dropped"]


def test_parts_already_packed_are_not_duplicated(tmp_path) -> None:
    """A crash between replacing the file and deleting the parts leaves stale parts."""
    out = tmp_path / "data.h5"
    write_episode(part_path(out, 0), 0, seed=0)
    stale = tmp_path / "stale.h5"
    stale.write_bytes(part_path(out, 0).read_bytes())
    pack(out)
    parts_dir(out).mkdir()
    stale.rename(part_path(out, 0))  # the part is back, as if its deletion never happened
    (parts_dir(out) / "episode_000001.h5.tmp").write_bytes(b"half an episode")
    status = scan(out)
    assert len(status.episodes) == 1 and len(status.stale) == 1 and len(status.leftovers) == 1
    pack(out)
    assert len(scan(out).episodes) == 1 and not parts_dir(out).exists()


def test_part_of_another_task_is_refused(tmp_path) -> None:
    out = tmp_path / "data.h5"
    write_episode(part_path(out, 0), 0, seed=0)
    pack(out)
    before = out.read_bytes()
    other = DatasetInfo(**{**INFO.__dict__, "task_id": "testlab/Other-v1"})
    write_episode(part_path(out, 1), 1, seed=1, info=other)
    with pytest.raises(DatasetError, match="holds episodes of task testlab/Synthetic-v1, not testlab/Other-v1"):
        pack(out)
    assert out.read_bytes() == before


def test_delete_episode_renumbers_and_checks_range(tmp_path) -> None:
    out = tmp_path / "data.h5"
    for i in range(3):
        write_episode(part_path(out, i), i, seed=20 + i)
    pack(out)
    before = out.read_bytes()
    with pytest.raises(DatasetError, match=r"episode 3 is out of range: .* has 3 episodes \(valid: 0..2\)"):
        delete_episode(out, 3)
    assert out.read_bytes() == before
    assert delete_episode(out, 1).seed == 21
    status = scan(out)
    assert [(r.index, r.summary.seed) for r in status.packed] == [(0, 20), (1, 22)]
    with h5py.File(out, "r") as f:
        assert sorted(f["episodes"]) == ["episode_000000", "episode_000001"]
        assert f["episodes/episode_000001"].attrs["index"] == 1


def test_delete_refuses_while_parts_are_pending(tmp_path) -> None:
    out = tmp_path / "data.h5"
    write_episode(part_path(out, 0), 0, seed=0)
    pack(out)
    write_episode(part_path(out, 1), 1, seed=1)
    before = out.read_bytes()
    with pytest.raises(DatasetError, match="pending"):
        delete_episode(out, 0)
    assert out.read_bytes() == before


def test_a_second_writer_stops_before_touching_the_file(tmp_path) -> None:
    out = tmp_path / "data.h5"
    write_episode(part_path(out, 0), 0, seed=0)
    pack(out)
    before = out.read_bytes()
    with writing(out, tmp_path / "." / "data.h5"):  # one file named twice is locked once
        assert lock_path(out).read_text() == f"{os.getpid()}\n"
        message = rf"data.h5 is being written by another run \(pid {os.getpid()}, lock .*data.h5.lock\)"
        with pytest.raises(DatasetError, match=message):
            delete_episode(out, 0)
        assert out.read_bytes() == before
    assert not lock_path(out).exists()  # released and removed with the block
    assert delete_episode(out, 0).seed == 0
    with writing(tmp_path / "new" / "deeper" / "x.h5"):  # folders made for the lock alone go with it
        assert (tmp_path / "new" / "deeper").is_dir()
    assert not (tmp_path / "new").exists()


@pytest.mark.parametrize("damage", ["garbage", "truncated", "foreign"])
def test_unreadable_files_give_one_clear_error_and_stay_untouched(tmp_path, damage: str) -> None:
    out = tmp_path / "data.h5"
    for i in range(2):
        write_episode(part_path(out, i), i, seed=i, steps=20)
    pack(out)
    if damage == "garbage":
        out.write_bytes(np.random.default_rng(0).bytes(4096))
        message = "not a readable HDF5 file"
    elif damage == "truncated":
        out.write_bytes(out.read_bytes()[: out.stat().st_size // 2])
        message = "not a readable HDF5 file .*truncated"
    else:
        out.unlink()
        with h5py.File(out, "w") as f:
            f["x"] = 1
        message = "not a Pipette episode file"
    before = out.read_bytes()
    for operation in (scan, pack, lambda p: delete_episode(p, 0)):
        with pytest.raises(DatasetError, match=message):
            operation(out)
        assert out.read_bytes() == before


def test_plan_seeds_continues_and_skips_used_seeds() -> None:
    assert plan_seeds(set(), 0, 3) == [0, 1, 2]
    assert plan_seeds({0, 1}, 2, 2) == [2, 3]
    assert plan_seeds({0, 2}, 2, 2) == [3, 4]  # after deleting seed 1: no seed is recorded twice
