"""Keyboard teleoperation driven by injected key codes (no display): paper A.5 increments, IK,
gripper toggle, save/discard/reset, and a teleoperated episode through the recorder."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from pipette_cli.demos.recorder import DatasetInfo, EpisodeWriter
from pipette_cli.demos.replay import replay_episode
from pipette_cli.demos.store import pack, part_path, scan
from pipette_cli.demos.teleop import KeyboardTeleop, glfw_key, require_display, teleop_episode
from pipette_cli.errors import PipetteError
from pipette_cli.registry import load_registry
from pipette_cli.sim.controllers import rotation_error
from pipette_cli.sim.env import PipetteEnv

pytestmark = pytest.mark.render
REGISTRY = Path(__file__).resolve().parents[1] / "fixtures" / "demos" / "registry"


@pytest.fixture(scope="module")
def env():
    env = PipetteEnv(load_registry([REGISTRY]).get("testlab/HoldTube-v1"), image_size=16)
    yield env
    env.close()


def _settled(env: PipetteEnv, sensitivity: float = 4.0) -> KeyboardTeleop:
    env.reset(0)
    teleop = KeyboardTeleop(env.world, sensitivity=sensitivity)
    hold = teleop.act(env.world)
    for _ in range(30):
        env.step(hold)
    return teleop


def _press(teleop: KeyboardTeleop, env: PipetteEnv, *keys: str) -> np.ndarray:
    for key in keys:
        teleop.on_key(glfw_key(key))
    return teleop.act(env.world)


def test_translation_key_moves_target_and_tcp_by_8_mm(env: PipetteEnv) -> None:
    teleop = _settled(env)
    p0, q0 = teleop.target_pos.copy(), teleop.target_quat.copy()
    tcp0 = env.world.tcp_position()
    action = _press(teleop, env, "W")
    np.testing.assert_allclose(teleop.target_pos - p0, [0.008, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(teleop.target_quat, q0, atol=1e-12)
    fk_pos, _fk_rot = teleop.ik.tcp_pose(action[:-1])  # the joint targets put the tcp on the target
    np.testing.assert_allclose(fk_pos - p0, [0.008, 0.0, 0.0], atol=2e-5)
    for _ in range(30):
        env.step(action)
    np.testing.assert_allclose(env.world.tcp_position() - tcp0, [0.008, 0.0, 0.0], atol=1e-3)  # the arm follows
    _press(teleop, env, "F", "F")  # two presses before one control step: two increments
    np.testing.assert_allclose(teleop.target_pos - p0, [0.008, 0.0, -0.016], atol=1e-12)


def test_rotation_key_turns_the_target_by_0_04_rad_about_the_tool_axis(env: PipetteEnv) -> None:
    teleop = _settled(env)
    q0 = teleop.target_quat.copy()
    action = _press(teleop, env, "O")
    expected = np.zeros(4)
    turn_about_z = np.zeros(4)
    mujoco.mju_axisAngle2Quat(turn_about_z, np.array([0.0, 0.0, 1.0]), 0.04)
    mujoco.mju_mulQuat(expected, q0, turn_about_z)
    np.testing.assert_allclose(teleop.target_quat, expected, atol=1e-12)
    assert np.linalg.norm(teleop.target_quat) == pytest.approx(1.0, abs=1e-12)
    _, rot0 = teleop.ik.tcp_pose(env.world.data.ctrl[env.world.arm_actuator_ids])
    _, rot1 = teleop.ik.tcp_pose(action[:-1])
    turn = rotation_error(rot1, rot0)  # world-frame axis-angle from old to new tcp orientation
    assert np.linalg.norm(turn) == pytest.approx(0.04, abs=2e-4)
    np.testing.assert_allclose(turn / np.linalg.norm(turn), rot0[:, 2], atol=1e-2)  # about the tool's z axis


def test_sensitivity_scales_the_increments(env: PipetteEnv) -> None:
    teleop = _settled(env, sensitivity=2.0)
    p0 = teleop.target_pos.copy()
    _press(teleop, env, "A")
    np.testing.assert_allclose(teleop.target_pos - p0, [0.0, 0.004, 0.0], atol=1e-12)
    assert teleop.rot_step == pytest.approx(0.02)


def test_gripper_toggle_events_and_unknown_keys(env: PipetteEnv) -> None:
    teleop = _settled(env)
    p0, targets = teleop.target_pos.copy(), teleop.joint_targets.copy()
    assert _press(teleop, env)[-1] == 1.0  # the task starts with the gripper open
    assert _press(teleop, env, "G")[-1] == 0.0
    assert _press(teleop, env, "G")[-1] == 1.0
    action = _press(teleop, env, "Z", "5")  # not mapped: nothing moves
    np.testing.assert_array_equal(teleop.target_pos, p0)
    np.testing.assert_array_equal(action[:-1], targets)
    for key in ("Enter", "Delete", "Home"):
        teleop.on_key(glfw_key(key))
    assert [teleop.pop_event(), teleop.pop_event(), teleop.pop_event(), teleop.pop_event()] == [
        "save",
        "discard",
        "reset",
        None,
    ]


def _script(teleop: KeyboardTeleop, plan: dict[int, list[str]]):
    """A stand-in for ``viewer.sync``: on its n-th call, press the keys ``plan[n]``."""
    calls = {"n": 0}

    def sync() -> None:
        calls["n"] += 1
        for key in plan.get(calls["n"], []):
            teleop.on_key(glfw_key(key))

    return sync


def test_teleoperated_episode_is_recorded_and_replays_exactly(env: PipetteEnv, tmp_path: Path) -> None:
    out = tmp_path / "teleop.h5"
    teleop = KeyboardTeleop(env.world)
    info = DatasetInfo.from_env(env)

    def episode(index: int, seed: int, plan: dict[int, list[str]]):
        writer = EpisodeWriter(part_path(out, index), info, index=index, seed=seed, source="teleop")
        outcome = teleop_episode(env, teleop, writer, max_steps=300, sync=_script(teleop, plan), realtime=False)
        return writer, outcome

    writer, outcome = episode(0, 7, {2: ["W", "W"], 3: ["R"], 5: ["G"], 9: ["Home"]})
    assert outcome.event == "reset" and not writer.tmp.exists()
    writer, outcome = episode(0, 7, {1: ["Delete"]})
    assert outcome.event == "discard" and not writer.tmp.exists()
    writer, outcome = episode(0, 8, {2: ["W", "W"], 3: ["R"], 5: ["G"], 12: ["Enter"]})
    assert outcome.event == "save" and outcome.summary is not None
    assert outcome.summary.num_steps == 12 and outcome.summary.reason == "stopped"  # saved before the 0.5 s timeout
    writer.commit()
    pack(out)
    record = scan(out).episode(0)
    assert record.summary.source == "teleop" and record.summary.seed == 8
    report = replay_episode(out, 0, env.task)
    assert report.ok, report.as_dict()


def test_a_finished_episode_waits_for_the_operator(env: PipetteEnv, tmp_path: Path) -> None:
    teleop = KeyboardTeleop(env.world)
    writer = EpisodeWriter(tmp_path / "e.h5", DatasetInfo.from_env(env), index=0, seed=0, source="teleop")
    decided = []
    outcome = teleop_episode(
        env,
        teleop,
        writer,
        max_steps=300,
        sync=_script(teleop, {40: ["Enter"]}),
        realtime=False,
        on_done=decided.append,
    )
    assert outcome.event == "save" and len(decided) == 1 and decided[0].reason == "not_lifted"
    assert outcome.summary.num_steps == 15 and outcome.summary.reason == "not_lifted"  # no steps after the verdict


def test_teleop_refuses_without_a_display(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(PipetteError, match="needs a display"):
        require_display()
