"""Bad scenes are refused at build time with the task id and the field."""

from __future__ import annotations

import pytest

from pipette_cli.errors import SimError
from pipette_cli.registry import load_registry
from pipette_cli.sim.robots import robot_config
from pipette_cli.sim.world import World

TUBE = load_registry().get("pipette/PickUpTestTube-v1")


def with_object_pose(pos: tuple[float, float, float]):
    obj = TUBE.scene.objects[0].model_copy(update={"pose": TUBE.scene.objects[0].pose.model_copy(update={"pos": pos})})
    scene = TUBE.scene.model_copy(update={"objects": [obj]})
    return TUBE.model_copy(update={"scene": scene})


def test_unknown_robot_names_the_known_ones() -> None:
    with pytest.raises(
        SimError,
        match=r"unknown robot 'kuka'; did you mean 'franka'\? \(robots: agilex_piper \(piper\), franka_panda \(panda\), ur5e_robotiq \(ur5e\)\)",
    ):
        robot_config("kuka")


def test_object_inside_the_bench_is_refused() -> None:
    with pytest.raises(SimError, match=r"PickUpTestTube-v1: scene.objects.0.pose: bench and tube interpenetrate"):
        World(with_object_pose((0.5, 0.0, 0.50)))


def test_unreachable_target_is_refused() -> None:
    with pytest.raises(SimError, match=r"scene.objects.0.pose: 'tube' is 1.20 m from the franka_panda base"):
        World(with_object_pose((1.2, 0.0, 0.55)))


def test_camera_on_a_missing_body_is_refused() -> None:
    top = TUBE.cameras.top.model_copy(update={"mount": "tube/no_such_body", "look_at": None, "euler_deg": (0, 0, 0)})
    task = TUBE.model_copy(update={"cameras": TUBE.cameras.model_copy(update={"top": top})})
    with pytest.raises(SimError, match=r"PickUpTestTube-v1: cameras.top.mount: no body 'tube/no_such_body'"):
        World(task)


def test_reference_to_a_missing_part_names_the_asset() -> None:
    world = World(TUBE)
    with pytest.raises(SimError, match="asset 'test_tube_16x150' has no site, body or joint 'lid'"):
        world.position("tube/lid")


def test_ur5e_with_robotiq_builds_and_grips() -> None:
    """The third embodiment: UR5e with the Robotiq 2F-85 at its attachment_site."""
    import numpy as np

    from pipette_cli.sim.robots import home_joints

    embodiment = TUBE.embodiment.model_copy(
        update={"robot": "ur5e_robotiq", "initial_joints": home_joints("ur5e_robotiq").tolist()}
    )
    world = World(TUBE.model_copy(update={"embodiment": embodiment}))
    world.reset(0)
    assert world.action_dim == 7 and world.state().shape == (7,)
    assert world.model.body("robot/gripper/base_mount").parentid == world.model.body("robot/wrist_3_link").id
    opened = world.state()[-1]
    for _ in range(30):
        world.step(np.append(world.arm_qpos(), 0.0))  # close
    assert world.state()[-1] > opened + 0.3  # the driver joint turns as the fingers close


def test_a_robot_not_on_this_machine_says_it_downloads_and_how_to_work_offline(monkeypatch, tmp_path, caplog) -> None:
    from pipette_cli.sim.robots import _menagerie_spec
    from pipette_cli.specs.robot import robot_spec

    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    monkeypatch.setenv("MENAGERIE_CACHE_DIR", str(tmp_path))  # nothing cached
    monkeypatch.setenv("MENAGERIE_BASE_URL", "http://127.0.0.1:9")  # nothing listens: refused at once
    with caplog.at_level("WARNING"), pytest.raises(SimError, match="MENAGERIE_ROOT to a local menagerie checkout"):
        _menagerie_spec(robot_spec("franka_panda").menagerie)
    assert "'franka_emika_panda': first use, downloading it from mujoco_menagerie" in caplog.text  # said before
