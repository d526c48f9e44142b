"""IK, the button mechanism (paper A.6) and passive lids, end to end in the real scenes."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from pipette_cli.registry import load_registry
from pipette_cli.sim.controllers import DifferentialIK
from pipette_cli.sim.world import World

REGISTRY = load_registry()
DOWN = np.diag([1.0, -1.0, -1.0])  # tcp z pointing at the bench, x forward


@pytest.mark.parametrize("task_id", ["PickUpTestTube", "PlaceFlaskOnShaker"])
def test_ik_recovers_reachable_poses(task_id: str) -> None:
    world = World(REGISTRY.get(task_id))
    world.reset(0)
    ik = DifferentialIK(world)
    rng = np.random.default_rng(0)
    home = world.arm_qpos()
    for _ in range(5):
        q_goal = home + rng.normal(0, 0.15, home.shape)
        q_goal = np.clip(q_goal, world.arm_range[:, 0], world.arm_range[:, 1])
        pos, rot = ik.tcp_pose(q_goal)
        result = ik.solve(pos, rot, q_start=home, iterations=100)
        assert result.position_error < 1e-3 and result.rotation_error < 1e-2, result
        reached, _ = ik.tcp_pose(result.qpos)
        np.testing.assert_allclose(reached, pos, atol=1e-3)
    np.testing.assert_array_equal(world.arm_qpos(), home)  # IK never touches the simulation


def move_to(world: World, q_start: np.ndarray, target: np.ndarray, steps: int = 40) -> np.ndarray:
    q = DifferentialIK(world).solve(target, DOWN, q_start=q_start, iterations=200).qpos
    for _ in range(steps):
        world.step(np.append(q, 0.0))
    return q


def test_pressing_the_button_opens_the_centrifuge_lid() -> None:
    world = World(REGISTRY.get("OpenCentrifugeLid"))
    world.reset(0)
    button = world.position("centrifuge/button")
    q = world.arm_qpos()
    q = move_to(world, q, np.array([0.2, button[1], 0.9]))
    q = move_to(world, q, button + [-0.08, 0.0, 0.0])
    assert not world.mechanism("lid_release").triggered
    assert world.joint("centrifuge/lid_hinge") == pytest.approx(0.0, abs=1.0)
    q = move_to(world, q, button + [-0.01, 0.0, 0.0], steps=10)
    state = world.mechanism("lid_release")
    assert state.triggered
    t_trigger = world.mechanisms["lid_release"].trigger_time
    verdict = world.verdict
    while not verdict.done:
        verdict = world.step(np.append(q, 0.0))
    assert verdict.success
    # the target ramps linearly to -40 deg over 2 s: -39 deg is passed at 39/40 of the ramp
    assert world.time - t_trigger == pytest.approx(2.0 * 39 / 40, abs=2 * world.control_dt)
    for _ in range(30):
        world.step(np.append(q, 0.0))
    assert world.joint("centrifuge/lid_hinge") == pytest.approx(-40.0, abs=3.0)


@pytest.mark.parametrize(
    ("task_id", "joint", "sign"),
    [
        ("CloseCentrifugeLid", "centrifuge/lid_hinge", -1.0),
        ("CloseSpectrophotometerLid", "spectro/lid_hinge", 1.0),
    ],
)
def test_open_lids_stay_open_and_contact_closes_them(task_id: str, joint: str, sign: float) -> None:
    world = World(REGISTRY.get(task_id))
    world.reset(0)
    hold = np.append(world.arm_qpos(), 1.0)
    hold[0] += 1.4  # park the arm to the side, out of the lid's sweep
    start = world.joint(joint)
    for _ in range(45):
        world.step(hold)
    assert abs(world.joint(joint) - start) < 3.0, "an open lid must stay open on its own"
    lid = world.model.jnt_bodyid[world.joint_id(joint)]
    verdict = world.verdict
    for _ in range(240):  # a hand pushing the lid over its hinge, like the robot would
        world.data.xfrc_applied[lid] = 0.0
        axis = world.data.xaxis[world.joint_id(joint)]
        lever = world.data.xipos[lid] - world.data.xanchor[world.joint_id(joint)]
        push = np.cross(axis, lever)
        push *= -np.sign(world.joint(joint)) / (np.linalg.norm(push) + 1e-9)
        world.data.xfrc_applied[lid, :3] = 8.0 * push
        verdict = world.step(hold)
        if verdict.done:
            break
    assert verdict.success, verdict
    assert abs(world.joint(joint)) < 5.0
    assert sign * start > 35.0  # it really started open
    mujoco.mj_resetData(world.model, world.data)
