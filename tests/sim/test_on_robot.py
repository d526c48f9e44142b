"""A task on another robot: home pose, wrist camera and a base pose it reaches from; refusals that
name the violated limit; the CLI's ``--robot``."""

from __future__ import annotations

import numpy as np
import pytest

from pipette_cli.demos.embodiment import check_payload, measure_workspace, on_robot, reachable_base
from pipette_cli.errors import InfeasibleTask, SimError
from pipette_cli.registry import load_registry
from pipette_cli.sim.world import World
from pipette_cli.specs.robot import robot_spec

REGISTRY = load_registry()


def test_the_task_s_own_robot_leaves_the_task_unchanged() -> None:
    task = REGISTRY.get("PickUpTestTube")
    assert on_robot(task, None) is task
    assert on_robot(task, "panda") is task
    assert on_robot(task, "franka_panda") is task


def test_another_robot_gets_its_home_pose_wrist_camera_and_a_base_that_reaches() -> None:
    task = REGISTRY.get("PlaceTubeOnBalance")
    piper = robot_spec("piper")
    placed = on_robot(task, "piper")
    assert placed.embodiment.robot == "agilex_piper"
    assert placed.embodiment.initial_joints == piper.arm.home
    assert placed.cameras.wrist.pos == piper.wrist_camera.pos
    base = np.asarray(placed.embodiment.base.pos)
    assert base[0] > 0.05 and base[2] == task.embodiment.base.pos[2]  # moved along the bench toward the work
    tube = np.asarray(placed.object("tube").pose.pos[:2])
    assert piper.min_reach <= np.linalg.norm(tube - base[:2]) <= piper.top_down_reach  # picked from above
    assert on_robot(task, "piper") == placed  # deterministic: a replay rebuilds the same scene
    World(placed)  # builds: nothing interpenetrates, every target within reach


def test_a_short_arm_starts_stowed_where_its_home_pose_would_reach_into_an_instrument() -> None:
    # the dish is on the incubator's shelf: the Piper must stand so close that its home pose's hand
    # would be inside the incubator, so it starts folded over its base (arm.stow)
    task = REGISTRY.get("RemovePetriDishFromIncubator")
    piper = robot_spec("piper")
    assert piper.arm.stow is not None
    placed = on_robot(task, "piper")
    assert placed.embodiment.initial_joints == piper.arm.stow
    base = np.asarray(placed.embodiment.base.pos)
    dish = np.asarray(placed.object("dish").pose.pos)
    assert abs(base[1]) < 1e-9  # straight in front of the door, not beside it
    assert np.linalg.norm(dish[:2] - base[:2]) <= 0.9 * piper.reach
    World(placed)  # builds: the stowed arm touches nothing
    unstowed = piper.model_copy(update={"arm": piper.arm.model_copy(update={"stow": None})})
    base_home, joints = reachable_base(placed, unstowed, measure_workspace(placed))
    assert joints == piper.arm.home and abs(base_home.pos[1]) > 0.1  # without it: beside the door


def test_an_unknown_robot_is_one_line_listing_the_robots() -> None:
    with pytest.raises(
        SimError, match=r"unknown robot 'kuka'.*robots: agilex_piper \(piper\), franka_panda \(panda\), ur5e_robotiq"
    ):
        on_robot(REGISTRY.get("PickUpTestTube"), "kuka")


def test_payload_and_reach_refusals_name_the_limit() -> None:
    task = on_robot(REGISTRY.get("PlaceFlaskOnShaker"), "panda")
    space = measure_workspace(task)
    assert 0.1 < space.carried["flask"] < 1.0
    weak = robot_spec("panda").model_copy(update={"payload_kg": 0.05})
    with pytest.raises(InfeasibleTask, match=r"payload: 'flask' weighs 0\.\d\d kg, over the robot's 0\.05 kg payload"):
        check_payload(task, weak, space)
    short = robot_spec("panda").model_copy(update={"reach": 0.1, "top_down_reach": 0.1})
    with pytest.raises(InfeasibleTask, match=r"reach: no base pose on the bench puts every work point"):
        reachable_base(task, short, space)


def test_a_spot_inside_an_enclosure_counts_at_its_front_and_where_the_hand_enters() -> None:
    # the shelf's centre is deep inside the incubator; place_on sets the dish down at the shelf's
    # front when the centre is out of reach, and the hand carries it in level through the mouth: the
    # base must leave that entry point outside the arm's min_reach
    task = REGISTRY.get("PlacePetriDishInIncubator")
    space = measure_workspace(task)
    shelf = "incubator/shelf_0_center"
    assert f"{shelf} (entry)" in space.points
    inside, entry = space.points[shelf], space.points[f"{shelf} (entry)"]
    assert 0.55 < inside[0] < 0.65  # the front of the shelf (its centre is at 0.755), still inside
    assert entry[0] < 0.5  # in front of the door opening (0.53), the dish clear of it
    piper = robot_spec("piper")
    base = np.asarray(on_robot(task, "piper").embodiment.base.pos)
    assert np.linalg.norm(entry[:2] - base[:2]) >= piper.min_reach
    assert "(entry)" not in " ".join(measure_workspace(REGISTRY.get("PlaceTubeOnBalance")).points)  # in the open


def test_a_flat_object_pinched_at_its_rim_counts_at_the_arm_s_full_reach() -> None:
    # a dish is pinched at its rim with the hand pitched, not taken straight down: the hand-down reach
    # does not bind it, so the Piper can stand back from the incubator and carry the dish in level
    # (standing close, the hand pointing in at the door is beyond its wrist: 10/20 at 0.25 m, 20/20 now)
    task = REGISTRY.get("PlacePetriDishInIncubator")
    assert measure_workspace(task).pinched == {"dish"}
    assert not measure_workspace(REGISTRY.get("PlaceTubeOnBalance")).pinched  # a tube: from above
    piper = robot_spec("piper")
    placed = on_robot(task, "piper")
    base = np.asarray(placed.embodiment.base.pos)
    dish = np.asarray(placed.object("dish").pose.pos)
    assert 0.9 * piper.top_down_reach < np.linalg.norm(dish[:2] - base[:2]) <= 0.9 * piper.reach
    assert placed.embodiment.initial_joints == piper.arm.home  # far enough from the door to start unfolded
