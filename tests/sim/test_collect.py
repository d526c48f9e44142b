"""Recording real episodes: bit-exact replay, worker-count independence, Ctrl-C and SIGKILL safety.

Uses the fixture task testlab/HoldTube-v1 (0.5 s timeout: 15 control steps) and the small
experts of tests/fixtures/demos/demo_experts.py, with 16-pixel images to stay fast.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from pipette_cli.demos.collect import collect
from pipette_cli.demos.replay import replay_episode
from pipette_cli.demos.store import lock_path, parts_dir, read_episode, scan
from pipette_cli.errors import DatasetError
from pipette_cli.registry import load_registry

pytestmark = pytest.mark.render
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "demos"
sys.path.insert(0, str(FIXTURES))
import demo_experts  # noqa: E402

REGISTRY = FIXTURES / "registry"
TASK_ID = "testlab/HoldTube-v1"


@pytest.fixture(scope="module")
def task():
    return load_registry([REGISTRY]).get(TASK_ID)


@pytest.fixture(scope="module")
def recorded(task, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("collect") / "wiggle.h5"
    result = collect(task, out, episodes=2, seed=5, image_size=16, expert_factory=demo_experts.Wiggle)
    assert [s.seed for s in result.added] == [5, 6] and result.total == 2
    return out


def test_recorded_episode_has_the_a3_contents(recorded: Path) -> None:
    status = scan(recorded)
    assert not status.pending and not parts_dir(recorded).exists()
    record = read_episode(status.episode(1), images=True)
    steps = record.summary.num_steps
    assert steps == 15 and record.summary.reason == "not_lifted"  # the 0.5 s timeout, nothing lifted
    assert record.images["wrist"].shape == (steps, 16, 16, 3)
    assert record.arrays["step"].tolist() == list(range(1, steps + 1))
    np.testing.assert_allclose(record.arrays["sim_time"], np.arange(steps) / 30, atol=1e-9)
    assert record.arrays["sim_state"][:, 0].tolist() == record.arrays["sim_time"].tolist()  # state starts with time
    assert np.all(np.diff(record.arrays["wall_time"]) > 0)
    for key in (
        "package_version",
        "code_sha256",
        "git_commit",
        "mujoco_version",
        "task_spec_sha256",
        "assets_sha256",
        "model_sha256",
    ):
        assert record.attrs[key], key
    assert "test_tube_16x150" in record.attrs["assets_sha256"]
    assert record.attrs["expert"].endswith("Wiggle")


def test_replay_reproduces_every_state_bit_exactly(recorded: Path, task) -> None:
    for index in range(2):
        report = replay_episode(recorded, index, task)
        assert report.states_compared == 15
        assert report.ok, report.as_dict()


def test_replay_detects_a_one_ulp_change_in_an_action(recorded: Path, task, tmp_path: Path) -> None:
    tampered = tmp_path / "tampered.h5"
    shutil.copy(recorded, tampered)
    with h5py.File(tampered, "r+") as f:
        actions = f["episodes/episode_000000/action"]
        row = actions[10]
        row[0] = np.nextafter(row[0], np.inf)
        actions[10] = row
    report = replay_episode(tampered, 0, task)
    assert not report.states_equal and report.first_mismatch == 11
    assert 0 < report.max_abs_diff < 1e-6


def made_by_other_code(path: Path) -> None:
    """Mark every episode of ``path`` as recorded by other code (another source, as an older checkout)."""
    with h5py.File(path, "r+") as f:
        for episode in f["episodes"].values():
            episode.attrs["code_sha256"] = "0123456789abcdef" * 4


def test_a_file_begun_by_other_code_takes_no_new_episodes_and_is_left_as_it_was(
    recorded: Path, task, tmp_path: Path
) -> None:
    older = tmp_path / "older.h5"
    shutil.copy(recorded, older)
    made_by_other_code(older)
    before = older.read_bytes()
    with pytest.raises(
        DatasetError, match=r"older\.h5 holds episodes made by pipette \S+ \(source 0123456789ab\).*mix two versions"
    ):
        collect(task, older, episodes=3, seed=5, image_size=16, expert_factory=demo_experts.Wiggle)
    assert older.read_bytes() == before and not parts_dir(older).exists()
    done = collect(task, older, episodes=2, seed=5, image_size=16, expert_factory=demo_experts.Wiggle)
    assert done.total == 2 and not done.added  # finished already: nothing to mix, nothing refused


def test_a_replay_says_when_other_code_recorded_the_episode(recorded: Path, task, tmp_path: Path) -> None:
    other = tmp_path / "other.h5"
    shutil.copy(recorded, other)
    made_by_other_code(other)
    assert replay_episode(recorded, 0, task).code_changed is None
    report = replay_episode(other, 0, task)
    assert report.ok  # other code that reproduces the states is no error; it is named all the same
    assert report.code_changed is not None and report.code_changed.startswith("recorded by pipette ")
    assert "(source 0123456789ab)" in report.code_changed and report.as_dict()["code_changed"] == report.code_changed


def test_the_same_code_under_another_commit_hash_goes_on_recording(recorded: Path, task, tmp_path: Path) -> None:
    again = tmp_path / "again.h5"  # as after `git am` of the same patch on another machine
    shutil.copy(recorded, again)
    with h5py.File(again, "r+") as f:
        for episode in f["episodes"].values():
            episode.attrs["git_commit"] = "0123456789abcdef" * 2 + "01234567"
    done = collect(task, again, episodes=3, seed=5, image_size=16, expert_factory=demo_experts.Wiggle)
    assert [s.seed for s in done.added] == [7] and done.total == 3


def test_the_file_does_not_depend_on_the_number_of_workers(recorded: Path, task, tmp_path: Path) -> None:
    out = tmp_path / "two_workers.h5"
    collect(task, out, episodes=2, seed=5, image_size=16, workers=2, expert_factory=demo_experts.Wiggle)
    for index in range(2):
        a = read_episode(scan(recorded).episode(index), images=True)
        b = read_episode(scan(out).episode(index), images=True)
        assert a.summary.seed == b.summary.seed
        for key in ("action", "state", "sim_state", "final_sim_state", "fresh", "frame_age"):
            assert a.arrays[key].tobytes() == b.arrays[key].tobytes(), key
        for camera in a.images:
            assert np.array_equal(a.images[camera], b.images[camera]), camera


def _cli_subprocess(out: Path, episodes: int) -> subprocess.Popen:
    """``pipette collect`` in a child process, with the Wiggle expert registered for HoldTube."""
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); import demo_experts; demo_experts.register(); "
        "from pipette_cli.cli.main import run; sys.argv = ['pipette', *sys.argv[2:]]; run()"
    )
    args = [
        sys.executable,
        "-c",
        code,
        str(FIXTURES),
        "--registry-dir",
        str(REGISTRY),
        "collect",
        TASK_ID,
        "--episodes",
        str(episodes),
        "--out",
        str(out),
        "--image-size",
        "16",
    ]
    return subprocess.Popen(
        args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env={**os.environ, "MUJOCO_GL": "egl"}
    )


def _wait_for_parts(
    out: Path, count: int, process: subprocess.Popen, *, writing: bool = False, timeout: float = 120.0
) -> None:
    """Wait until ``count`` finished parts exist (and, with ``writing``, the next one is being written)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        folder = parts_dir(out)
        if folder.is_dir() and len(list(folder.glob("episode_*.h5"))) >= count:
            if not writing or list(folder.glob("episode_*.h5.tmp")):
                return
        assert process.poll() is None, process.communicate()
        time.sleep(0.01)
    raise AssertionError(f"no {count} parts within {timeout} s")


def test_sigkill_mid_run_leaves_a_readable_file_and_a_rerun_resumes(task, tmp_path: Path) -> None:
    out = tmp_path / "killed.h5"
    collect(task, out, episodes=1, image_size=16, expert_factory=demo_experts.Wiggle)
    before = out.read_bytes()
    process = _cli_subprocess(out, episodes=8)
    _wait_for_parts(out, 2, process, writing=True)
    with pytest.raises(DatasetError, match=rf"killed.h5 is being written by another run \(pid {process.pid},"):
        collect(task, out, episodes=8, image_size=16, expert_factory=demo_experts.Wiggle)  # a second run stops
    process.send_signal(signal.SIGKILL)  # while an episode is being written
    process.wait()
    assert out.read_bytes() == before  # the file itself was never touched
    status = scan(out)  # readable, with the finished episodes pending
    seeds = [r.summary.seed for r in status.episodes]
    assert seeds[:3] == [0, 1, 2] and len(seeds) < 8 and status.leftovers
    resumed = collect(task, out, episodes=5, image_size=16, expert_factory=demo_experts.Wiggle)
    assert [s.seed for s in resumed.added] == list(range(len(seeds), 5))
    final = scan(out)
    assert [r.summary.seed for r in final.packed] == [0, 1, 2, 3, 4] and not final.pending and not final.leftovers
    assert not parts_dir(out).exists() and not lock_path(out).exists()  # the dead run's lock went with it
    assert replay_episode(out, 1, task).ok  # an episode written by the killed run replays exactly


def test_ctrl_c_packs_finished_episodes_and_exits_130(tmp_path: Path) -> None:
    out = tmp_path / "interrupted.h5"
    process = _cli_subprocess(out, episodes=20)
    _wait_for_parts(out, 1, process)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert b"run the same command again to resume" in stderr
    status = scan(out)
    assert 1 <= len(status.packed) < 20 and not status.pending and not parts_dir(out).exists()
