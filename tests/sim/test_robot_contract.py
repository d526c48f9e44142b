"""The contract every robot of ``registry/robots/`` keeps (docs/robots.md, "Adding a robot").

Parametrised over every registered robot, so a new ``registry/robots/X.yaml`` is checked without
editing this file: the menagerie model loads, the home pose is inside the joint limits and free of
self-collision, the ``tcp`` site exists with the canonical frame, the binary gripper command really
opens and closes the fingers, IK reaches points well inside the stated reach, and the test-tube pick
(the skill program of PickUpTestTube, unchanged) succeeds with the robot placed on the bench.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from pipette_cli.demos.check import run_expert_episode
from pipette_cli.demos.embodiment import on_robot
from pipette_cli.registry import load_registry
from pipette_cli.sim.robots import gripper_ctrl, make_robot_spec, match_options
from pipette_cli.sim.world import World
from pipette_cli.skills.ik import ArmIK
from pipette_cli.specs.robot import load_robot_specs, robot_names

ROBOTS = robot_names()
PREFIX = "r/"


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture(scope="module")
def tube_world(robot: str) -> World:
    """PickUpTestTube with ``robot`` placed by ``on_robot`` (its home pose, a base that reaches)."""
    return World(on_robot(load_registry().get("PickUpTestTube"), robot))


def _alone(name: str, pose: str = "home") -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The robot alone, standing at the origin, arm at home (or in its stow pose)."""
    spec, config = make_robot_spec(name)
    joints = config.home() if pose == "home" else np.asarray(load_robot_specs()[name].arm.stow)
    scene = mujoco.MjSpec()
    match_options(spec, scene)
    scene.attach(spec, prefix=PREFIX, frame=scene.worldbody.add_frame())
    model = scene.compile()
    data = mujoco.MjData(model)
    for joint, value in zip(config.arm_joints, joints, strict=True):
        data.qpos[model.joint(PREFIX + joint).qposadr[0]] = value
        data.ctrl[model.actuator(PREFIX + config.arm_actuators[config.arm_joints.index(joint)]).id] = value
    mujoco.mj_forward(model, data)
    return model, data


def test_model_loads_with_every_named_part(robot: str) -> None:
    config = load_robot_specs()[robot]
    model, _ = _alone(robot)
    for joint in (*config.arm_joints, config.gripper.joint):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, PREFIX + joint) >= 0, joint
    for actuator in (*config.arm_actuators, config.gripper.actuator):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, PREFIX + actuator) >= 0, actuator
    for body in (config.end_effector.body, config.end_effector.wrist_camera_body):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, PREFIX + body) >= 0, body


def test_home_and_stow_are_inside_the_joint_limits_and_free_of_self_collision(robot: str) -> None:
    config = load_robot_specs()[robot]
    poses = {"home": config.arm.home} | ({"stow": config.arm.stow} if config.arm.stow is not None else {})
    for pose, joints in poses.items():
        model, data = _alone(robot, pose)
        for joint, value in zip(config.arm_joints, joints, strict=True):
            j = model.joint(PREFIX + joint)
            if model.jnt_limited[j.id]:
                low, high = j.range
                assert low <= value <= high, f"{joint}: {pose} {value} outside [{low}, {high}]"
        penetrating = [
            (model.body(model.geom_bodyid[c.geom1]).name, model.body(model.geom_bodyid[c.geom2]).name)
            for c in data.contact[: data.ncon]
            if c.dist < -1e-3
        ]
        assert not penetrating, (pose, penetrating)


def test_tcp_frame_points_the_fingers_and_closes_across_them(tube_world: World) -> None:
    """At home the tool hangs over the bench: z (approach) points down, in front of the base."""
    world = tube_world
    world.reset(0)
    rot = world.tcp_rotation()
    assert rot[2, 2] < -0.8, f"tcp approach axis {rot[:, 2]} does not point down at home"
    base = np.asarray(world.task.embodiment.base.pos)
    assert world.tcp_position()[2] > base[2] + 0.15
    assert np.linalg.norm(world.tcp_position()[:2] - base[:2]) < world.robot.reach


def test_binary_gripper_command_opens_and_closes_the_fingers(tube_world: World) -> None:
    world = tube_world
    world.reset(0)
    home = world.robot.home()
    low, high = world.gripper_range
    positions = {}
    for command in (0.0, 1.0, 0.0):
        for _ in range(20):  # 0.67 s
            world.step(np.append(home, command))
        positions[command] = world.data.qpos[world.gripper_qpos_adr]
    travel = abs(positions[1.0] - positions[0.0])
    assert travel > 0.5 * (high - low), f"the fingers moved {travel:.4f} of a {high - low:.4f} range"
    # "open" is the end of the range that the facts' open control drives toward
    opens_high = world.robot.gripper.open_ctrl > world.robot.gripper.closed_ctrl
    assert (positions[1.0] > positions[0.0]) == opens_high


def test_the_fingers_close_and_open_smoothly(tube_world: World) -> None:
    """The gripper's velocity keeps its sign while it moves: with the servo's damping in the servo,
    MuJoCo's implicit step dropped it once the Panda's force hit its 100 N limit, and the fingers
    flipped direction on every physics step (-0.5, +0.2, -0.5 m/s); they bounced off a 3 g cuvette
    and stopped 19 mm open."""
    world = tube_world
    world.reset(0)
    model, data = world.model, world.data
    dof = model.jnt_dofadr[model.joint(f"robot/{world.robot.gripper.joint}").id]
    for command in (1.0, 0.0, 1.0):  # from closed (a reset's joint zero)
        data.ctrl[world.gripper_actuator_id] = gripper_ctrl(world.robot, command)
        speeds = []
        for _ in range(int(0.3 / model.opt.timestep)):
            mujoco.mj_step(model, data)
            speeds.append(float(data.qvel[dof]))
        moving = np.array([v for v in speeds if abs(v) > 0.01])
        flips = int(np.sum(np.sign(moving[1:]) != np.sign(moving[:-1])))
        assert len(moving) > 10 and flips <= 2, f"{flips} reversals in {len(moving)} moving steps"


@pytest.mark.parametrize(("fraction", "pitch_deg"), [(0.5, 0.0), (0.8, 30.0)])
def test_ik_reaches_points_well_inside_the_stated_reach(tube_world: World, fraction: float, pitch_deg: float) -> None:
    """The stated reach is for a grasp 10 cm over the bench with the hand tilted 30 deg away from
    the robot; half of it is reached pointing straight down."""
    world = tube_world
    world.reset(0)
    base = np.asarray(world.task.embodiment.base.pos)
    pitch = np.deg2rad(pitch_deg)
    approach = np.array([np.sin(pitch), 0.0, -np.cos(pitch)])  # down, tipped away from the base
    across = np.array([0.0, -1.0, 0.0])
    rot = np.column_stack([np.cross(across, approach), across, approach])
    target = base + np.array([fraction * world.robot.reach, 0.0, 0.1])
    solution = ArmIK(world).reachable(target, rot, world.arm_qpos())
    assert solution.ok(), f"IK misses {target} by {solution.position_error * 1000:.0f} mm"


def test_the_test_tube_pick_succeeds(tube_world: World) -> None:
    verdict, failure = run_expert_episode(tube_world, seed=0)
    assert failure is None, failure
    assert verdict.success, verdict.reason
