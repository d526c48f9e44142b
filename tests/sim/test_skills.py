"""Each skill on at least two assets of different shape, judged by where things end up.

The programs run closed loop in real physics; the assertions are on the world afterwards (the object
in the hand, on the surface, in the slot; the lid shut; the drawer out), not on the plan.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from pipette_cli.demos.embodiment import on_robot
from pipette_cli.errors import SimError
from pipette_cli.registry import load_registry
from pipette_cli.sim.world import World
from pipette_cli.skills.program import ProgramExpert
from pipette_cli.specs.expert import (
    CloseHingeSpec,
    MoveSpec,
    PickSpec,
    PositionOverSpec,
    PressSpec,
    RemoveFromSpec,
    RetreatSpec,
    StepSpec,
    TiltSpec,
    WaitSpec,
)

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "skills"
REGISTRY = load_registry([FIXTURES])


def run(
    task_id: str,
    steps: list[StepSpec] | None = None,
    seed: int = 0,
    seconds: float = 25.0,
    watch: Callable[[World], None] | None = None,
    robot: str | None = None,
) -> tuple[World, ProgramExpert]:
    """Run a program (the task's own by default) to its end, whatever the evaluator says; `watch` sees
    every step. ``robot``: on another robot (placed by ``on_robot``)."""
    task = on_robot(REGISTRY.get(task_id), robot)
    world = World(task)
    world.reset(seed)
    expert = ProgramExpert(steps if steps is not None else list(task.expert or []))
    expert.reset(world, np.random.default_rng(seed))
    for _ in range(int(seconds / world.control_dt)):
        world.step(expert.act(world))
        if watch is not None:
            watch(world)
        if expert.failure or expert.done:
            break
    for _ in range(int(0.5 / world.control_dt)):  # let what was set down settle
        world.step(expert.act(world))
    assert expert.failure is None, expert.failure
    assert expert.done
    return world, expert


def upright(world: World, name: str) -> float:
    """Degrees the object's own z axis leans from the vertical."""
    return float(np.rad2deg(np.arccos(np.clip(world.rotation(name)[2, 2], -1.0, 1.0))))


@pytest.mark.parametrize(
    ("task_id", "name", "lift"),
    [
        ("PickUpTestTube", "tube", 0.1),  # upright tube, about its axis
        ("PlacePetriDishInIncubator", "dish", 0.05),  # flat dish, pinched at the rim
        ("skills/PickTurnedDish-v1", "dish", 0.05),  # turned about the vertical: as wide as ever
        ("PipetteToPetriDish", "pipette", 0.1),  # lying tool, across its body
        ("skills/PickLyingTools-v1", "syringe", 0.08),  # low lying tools too, whatever their yaw
        ("skills/PickLyingTools-v1", "marker", 0.08),
    ],
)
def test_pick_lifts_objects_of_every_shape(task_id: str, name: str, lift: float) -> None:
    world = World(REGISTRY.get(task_id))
    world.reset(0)
    start = world.position(name)
    world, expert = run(task_id, [PickSpec(object=name, lift=lift, hold_s=0.5)])
    assert world.position(name)[2] - start[2] > 0.6 * lift
    assert expert._ctx is not None and expert._ctx.hand.held is not None and expert._ctx.hand.held.name == name


@pytest.mark.parametrize("seed", [0, 1])
def test_pick_takes_a_small_upright_object_without_tipping_it(seed: int) -> None:
    """A 2 mL cryovial, light and tall: the first finger to touch it must not push it over."""
    leans: list[float] = []
    world, _ = run("skills/PickSmallUpright-v1", seed=seed, watch=lambda w: leans.append(upright(w, "vial")))
    assert world.verdict.success, world.verdict
    assert max(leans) < 10.0, f"the cryovial leaned {max(leans):.0f} deg on the way"


def test_place_on_sets_a_tube_on_a_pan_and_a_dish_on_a_shelf() -> None:
    world, _ = run("PlaceTubeOnBalance")
    pan = world.position("balance/pan_center")
    assert (
        np.linalg.norm(world.position("tube")[:2] - pan[:2]) < 0.02 and abs(world.position("tube")[2] - pan[2]) < 0.01
    )
    assert upright(world, "tube") < 8
    world, _ = run("PlacePetriDishInIncubator")
    shelf = world.position("incubator/shelf_0_center")
    dish = world.position("dish")
    assert abs(dish[2] - shelf[2]) < 0.01 and abs(dish[1] - shelf[1]) < 0.05 and dish[0] > 0.6  # on the shelf, inside
    assert upright(world, "dish") < 5  # kept level


def test_insert_into_a_rack_hole_and_a_pipette_stand() -> None:
    world, _ = run("skills/TubeIntoRack-v1")
    slot = world.position("rack/slot_5")
    assert (
        np.linalg.norm(world.position("tube")[:2] - slot[:2]) < 0.006
        and abs(world.position("tube")[2] - slot[2]) < 0.01
    )
    world, _ = run("PlacePipetteInRack", seconds=30)
    slot = world.position("rack/slot_1")
    tip = world.position("pipette/tip")
    assert np.linalg.norm(tip[:2] - slot[:2]) < 0.012  # hanging in the slot
    assert upright(world, "pipette") < 10


@pytest.mark.parametrize(
    ("task_id", "tube", "slot", "seed", "off"),
    [
        # a 16 x 150 mm test tube in an 18 mm hole of a 60 mm rack: seated, it may lean on the wall
        ("skills/TubeIntoRack-v1", "tube", "rack/slot_5", 0, 0.003),
        # a 1.5 mL microtube taken by its top out of a rotor well: the fingers would land on the rack's
        # top grid 8 mm before it is seated, and it was let go 3 mm off its hole (it tipped); within
        # 2 mm its cone, in the hole first, centres it
        ("protocols/UnloadMicrocentrifuge-v1", "tube", "rack/slot_9", 0, 0.002),
        # the arm outstretched over the rotor sagged 4 mm as it closed: the tube, held that much lower
        # than planned, was let go 9 mm over its seat with only its cone in the hole and tipped 22
        # degrees; the hand is raised to its planned height before the fingers close
        ("protocols/UnloadMicrocentrifuge-v1", "tube", "rack/slot_9", 2, 0.002),
    ],
)
def test_insert_into_is_measured_against_the_hole(task_id: str, tube: str, slot: str, seed: int, off: float) -> None:
    """Lined up by where the tube is (not where the arm was told to go), put in no deeper than the
    closed fingers allow over the rack, let go without dragging it: it stands in its hole."""
    task = REGISTRY.get(task_id)
    world = World(task)
    world.reset(seed)
    steps = list(task.expert or [])
    insert = next(i for i, s in enumerate(steps) if s.skill == "insert_into")
    expert = ProgramExpert(steps)
    expert.reset(world, np.random.default_rng(seed))
    pressed, released_off = 0, None
    for _ in range(int(40.0 / world.control_dt)):
        action = expert.act(world)
        holding = expert.step_index == insert and expert._ctx is not None and expert._ctx.hand.held is not None
        if holding and world.robot_touches("rack"):
            pressed += 1
        if released_off is None and expert.step_index == insert and action[-1] >= 0.5:  # the fingers open
            released_off = float(np.linalg.norm(world.position(tube)[:2] - world.position(slot)[:2]))
        world.step(action)
        if expert.failure or expert.done or expert.step_index > insert:
            break
    assert expert.failure is None, expert.failure
    assert released_off is not None and released_off < off, f"let go {released_off} m off the hole's axis"
    assert pressed == 0, f"the fingers pressed on the rack for {pressed} steps"
    for _ in range(int(0.5 / world.control_dt)):
        world.step(expert.act(world))
    assert np.linalg.norm(world.position(tube)[:2] - world.position(slot)[:2]) < 0.005
    assert world.position(tube)[2] - world.position(slot)[2] < 0.012  # in the hole, not on its rim
    assert upright(world, tube) < 10.0


def test_a_tall_tube_goes_from_one_rack_into_another() -> None:
    world, _ = run("skills/TallTubeRackToRack-v1", seconds=15.0)
    assert world.verdict.success, world.verdict.reason
    assert upright(world, "tube") < 5.0


def test_remove_from_a_balance_to_the_bench_and_out_of_an_incubator() -> None:
    world = World(REGISTRY.get("RemoveTubeFromBalance"))
    world.reset(0)
    start = world.position("tube")
    world, _ = run("RemoveTubeFromBalance")
    end = world.position("tube")
    assert end[1] - start[1] > 0.25 and abs(end[2] - 0.55) < 0.01 and upright(world, "tube") < 10
    world, _ = run(
        "RemovePetriDishFromIncubator", [RemoveFromSpec(object="dish", source="incubator", to="hold", hold_s=0.5)]
    )
    dish = world.position("dish")
    assert dish[0] < 0.55 and dish[2] > 0.6  # out in front, held clear


def test_remove_from_an_incubator_onto_the_bench_close_in_front_of_the_robot() -> None:
    # the straight leg from the incubator's mouth down to over the spot is judged point by point: high
    # over the shelf it leaves, low over the bench (new-task's layout of "Take the petri dish out of
    # the incubator", 0/5 while the way's highest surface was held against its lowest end)
    world, _ = run("skills/DishOutToNearBench-v1")
    dish = world.position("dish")
    assert dish[0] < 0.77 - 0.222 and abs(dish[1]) < 0.03 and dish[2] < 0.56  # out in front, on the bench (0.55)
    assert not world.robot_touches("dish") and upright(world, "dish") < 10


@pytest.mark.parametrize(
    ("task_id", "joint"),
    [
        ("CloseCentrifugeLid", "centrifuge/lid_hinge"),  # heavy lid, opens toward the robot
        ("CloseSpectrophotometerLid", "spectro/lid_hinge"),  # light lid leaning back past upright
        ("generated/CloseThermalCyclerLid-v1", "cycler/lid_hinge"),
    ],
)
def test_close_hinge_shuts_lids(task_id: str, joint: str) -> None:
    world, _ = run(task_id, [CloseHingeSpec(joint=joint, hold_s=0.3)])
    assert abs(world.joint(joint)) < 4


@pytest.mark.parametrize("seed", [2, 3])
def test_a_short_arm_closes_a_lid_leaning_back_coming_down_behind_it(seed: int) -> None:
    # the spectrophotometer's lid stands past upright, 0.5 m out from the Piper: coming in level from
    # behind it, the wrist of the pitched hand would cross the lid; from above, down its back, it does not
    world, _ = run("CloseSpectrophotometerLid", seed=seed, robot="piper")
    assert abs(world.joint("spectro/lid_hinge")) < 5


def test_a_short_arm_carries_a_dish_into_an_incubator() -> None:
    world, _ = run("PlacePetriDishInIncubator", seed=0, robot="piper")
    dish = world.position("dish")
    assert dish[0] > 0.55 and dish[2] > 0.6  # on the shelf, inside


def test_a_hung_pipette_counts_once_the_hand_lets_go() -> None:
    # carried over the stand, the pipette is inside the paper's bounds long before it hangs there
    task = REGISTRY.get("PlacePipetteInRack")
    world = World(task)
    world.reset(0)
    expert = ProgramExpert(list(task.expert or []))
    expert.reset(world, np.random.default_rng(0))
    carried_inside, verdict = 0, world.verdict
    while not verdict.done and world.step_count < 700:
        verdict = world.step(expert.act(world))
        pos = world.position("pipette")
        carried_inside += bool(pos[1] > 0.14 and pos[2] > 0.58 and world.robot_touches("pipette"))
    assert verdict.success
    assert carried_inside > 30  # over a second: the paper's bounds alone would have stopped it there
    assert not world.robot_touches("pipette") and world.position("pipette")[2] == pytest.approx(0.608, abs=0.01)
    with pytest.raises(SimError, match="names no scene object"):
        world.robot_touches("beaker")


def test_the_ur5e_turns_the_pipette_upright_without_dragging_it_to_the_bench() -> None:
    # a quarter turn of the hand is 2.6 rad of the UR5e's wrist, whose model drives it at under 1 rad/s:
    # a straight move timed by the tool alone left the wrist behind and the hand swept down to the bench
    carried: list[float] = []  # the pipette's height while held, from when it was first lifted high

    def watch(world: World) -> None:
        z = float(world.position("pipette")[2])
        if world.robot_touches("pipette") and (carried or z > 0.75):
            carried.append(z)

    world, _ = run("PlacePipetteInRack", seed=0, seconds=30, robot="ur5e_2f85", watch=watch)
    assert min(carried) > 0.58  # hung at 0.608, slid in 5 mm over that: never back down at the bench (0.55)
    assert not world.robot_touches("pipette") and world.position("pipette")[2] == pytest.approx(0.608, abs=0.01)


@pytest.mark.parametrize("robot", ["franka_panda", "piper", "ur5e_2f85"])
def test_every_robot_hangs_the_pipette_and_lets_go(robot: str) -> None:
    # seed 2: the Piper cannot turn the pipette upright on the way, so it stands it up where it picked
    # it; every robot slides it into the stand's slot from the open front
    world, _ = run("PlacePipetteInRack", seed=2, seconds=30, robot=robot)
    assert not world.robot_touches("pipette") and world.position("pipette")[2] == pytest.approx(0.608, abs=0.01)


def test_a_pipette_held_upright_does_not_turn_in_the_piper_s_fingers() -> None:
    # the Piper's fingers are single thin plates: at MuJoCo's default torsional friction an upright
    # pipette turned 4 deg in 5 s in them (too much to slide it in), with its second finger, coupled
    # by a soft equality, squeezing at 3 N per contact
    upright: list[np.ndarray] = []  # the pipette's rotation in the hand while held upright

    def watch(world: World) -> None:
        rot = world.rotation("pipette")
        if world.robot_touches("pipette") and rot[2, 2] > 0.97:
            upright.append(world.tcp_rotation().T @ rot)

    run("PlacePipetteInRack", seed=2, seconds=30, robot="piper", watch=watch)
    assert len(upright) > 60  # over two seconds held upright
    turned = max(np.degrees(np.arccos(np.clip((np.trace(upright[0].T @ r) - 1) / 2, -1, 1))) for r in upright)
    assert turned < 2.0, f"the pipette turned {turned:.1f} deg in the fingers"


def test_open_hinge_pulls_a_door_and_pushes_it_open() -> None:
    """A door on a vertical hinge, pulled by its bar as far as the arm follows (the hand turning less
    with it on the way), then pushed open with the fingertips on its inner face."""
    world, _ = run("skills/OpenIncubatorDoor-v1")
    assert world.joint("incubator/door_hinge") > 60.0


def test_press_fires_the_release_of_two_centrifuges() -> None:
    for task_id, button, mechanism in (
        ("OpenCentrifugeLid", "centrifuge/button", "lid_release"),
        ("generated/PressMicrocentrifugeButton-v1", "microcentrifuge/button", "release"),
    ):
        world, _ = run(task_id, [PressSpec(button=button), WaitSpec(seconds=0.3)])
        assert world.mechanism(mechanism).triggered, task_id


def test_slide_pulls_a_drawer_out() -> None:
    world, _ = run("skills/OpenReaderDrawer-v1")
    assert world.joint("reader/drawer_slide") > 0.12


def test_position_over_holds_a_tool_tip_over_a_target() -> None:
    world, _ = run(
        "PipetteToPetriDish",
        [PickSpec(object="pipette"), PositionOverSpec(object="pipette", target="dish/center", height=0.1, hold_s=0.5)],
    )
    tip, dish = world.position("pipette/tip"), world.position("dish/center")
    assert np.linalg.norm(tip[:2] - dish[:2]) < 0.02 and abs(tip[2] - dish[2] - 0.1) < 0.02


def test_tilt_and_move_carry_a_tube_and_tilt_it_back() -> None:
    world = World(REGISTRY.get("PickUpTestTube"))
    world.reset(0)
    start = world.position("tube")
    leans: list[float] = []
    world, _ = run(
        "PickUpTestTube",
        [
            PickSpec(object="tube", lift=0.08),
            MoveSpec(by=(0.0, 0.05, 0.0)),
            TiltSpec(object="tube", angle_deg=30, hold_s=0.3),
        ],
        watch=lambda w: leans.append(upright(w, "tube")),
    )
    assert world.position("tube")[1] - start[1] > 0.035  # carried sideways
    assert max(leans) > 20  # tilted on the way
    assert upright(world, "tube") < 8  # and back upright at the end


def test_retreat_lets_go_and_goes_home() -> None:
    world, _ = run("PickUpTestTube", [PickSpec(object="tube", lift=0.05), RetreatSpec(distance=0.05, home=True)])
    assert np.linalg.norm(world.arm_qpos() - world.robot.home()) < 0.1
    assert world.position("tube")[2] < 0.6  # let go: it fell back to the bench


def test_same_seed_same_skill_actions() -> None:
    def actions() -> np.ndarray:
        world = World(REGISTRY.get("skills/TubeIntoRack-v1"))
        world.reset(4)
        expert = ProgramExpert(list(world.task.expert or []))
        expert.reset(world, np.random.default_rng(4))
        out = []
        for _ in range(120):
            out.append(expert.act(world))
            world.step(out[-1])
        return np.array(out)

    np.testing.assert_array_equal(actions(), actions())


def test_moves_give_a_damped_joint_the_time_its_actuator_needs() -> None:
    """The UR5e's wrists (28 Nm against damping 20) top out near 1.4 rad/s: a move that swings a
    wrist is timed by that joint, not by the tool's speed; the Panda's joints are not held back."""
    from pipette_cli.skills.moves import TRANSIT_SPEED
    from pipette_cli.skills.runtime import JOINT_SPEED_SHARE, MIN_JERK_PEAK, SkillContext, joint_speeds

    task = REGISTRY.get("PickUpTestTube")
    ur5e = World(on_robot(task, "ur5e"))
    speeds = joint_speeds(ur5e)
    assert speeds[3:] == pytest.approx([JOINT_SPEED_SHARE * 28.0 / 20.0] * 3)
    ctx = SkillContext(ur5e, np.random.default_rng(0))
    swing = ctx.hand.q + np.array([0.0, 0.0, 0.0, 1.5, 0.0, 0.0])
    assert ctx.duration(ctx.hand.pos, ctx.hand.rot, TRANSIT_SPEED, swing) == pytest.approx(
        MIN_JERK_PEAK * 1.5 / speeds[3]
    )
    panda = SkillContext(World(task), np.random.default_rng(0))
    nudge = panda.hand.q + 0.05
    far = panda.hand.pos + np.array([0.3, 0.0, 0.0])
    assert panda.duration(far, panda.hand.rot, TRANSIT_SPEED, nudge) == pytest.approx(0.3 / TRANSIT_SPEED)


def test_a_short_arm_takes_a_lid_handle_bar_from_in_front() -> None:
    """The Piper cannot reach over the water bath's handle bar: it takes it from in front, the hand
    level and the lower finger under the bar, and lifts the lid off (the Panda still comes from
    above). The way into that grasp turns the wrist a lot on a short way, which the arm follows
    through joint space: a straight line would run its forearm roll into its limit."""
    from pipette_cli.skills.grasp import plan_grasp
    from pipette_cli.skills.runtime import SkillContext

    piper = World(on_robot(REGISTRY.get("OpenWaterBathLid"), "piper"))
    piper.reset(0)
    grasp = plan_grasp(SkillContext(piper, np.random.default_rng(0)), "lid", at="lid/lid_handle")
    bar = piper.model.geom("lid/handle_bar_col").id
    bar_bottom = piper.data.geom_xpos[bar][2] - piper.model.geom_size[bar][2]
    assert grasp.kind == "front" and abs(grasp.rot[2, 2]) < 0.05  # level
    assert grasp.pos[2] - piper.robot.gripper.max_opening / 2 < bar_bottom  # the lower finger under the bar
    panda = World(REGISTRY.get("OpenWaterBathLid"))
    panda.reset(0)
    assert plan_grasp(SkillContext(panda, np.random.default_rng(0)), "lid", at="lid/lid_handle").kind == "top"

    start = piper.position("lid").copy()
    world, _ = run("OpenWaterBathLid", robot="piper")
    moved = world.position("lid") - start
    assert moved[2] > 0.10 and moved[0] < -0.30  # the task's criterion: lifted and drawn back


def test_a_dry_run_can_ask_for_room_around_the_arm() -> None:
    # the hand pointing down, its fingertips 1 cm over the bench top: it touches nothing, but is within
    # 1.5 cm of the bench; a fast joint-space transit (whose joints trail their targets) keeps that room
    from pipette_cli.skills.frames import down_frame
    from pipette_cli.skills.moves import TRANSIT_ROOM
    from pipette_cli.skills.runtime import SkillContext

    world = World(REGISTRY.get("PickUpTestTube"))
    world.reset(0)
    ctx = SkillContext(world, np.random.default_rng(0))
    top = ctx.scene.surface_below(0.4, 0.25, set(), from_z=1.0)
    pos = np.array([0.4, 0.25, top + 0.01 + ctx.robot.gripper.fingertip])
    solution = ctx.plan.solve(pos, down_frame(np.array([0.0, 1.0, 0.0])), ctx.hand.q)
    assert solution.ok()
    bench = {b for b in range(world.model.nbody) if world.model.body(b).name.startswith("bench")}
    assert not any(other in bench for _, other in ctx.plan.hits(solution.qpos))
    assert any(other in bench for _, other in ctx.plan.hits(solution.qpos, room=TRANSIT_ROOM))
    assert world.model.geom_margin.max() == 0.0  # the world's own physics is untouched


def test_no_straight_tool_line_turns_the_hand_half_a_turn() -> None:
    """A parallel gripper's flip is exactly half a turn, whose shorter arc is either way round: a
    straight line never makes it (the move goes through joint space); a quarter turn it may."""
    from pipette_cli.skills.frames import axis_rotation, down_frame
    from pipette_cli.skills.moves import FLIP, TRANSIT_SPEED, Leg
    from pipette_cli.skills.runtime import SkillContext

    world = World(REGISTRY.get("PickUpTestTube"))
    world.reset(0)
    ctx = SkillContext(world, np.random.default_rng(0))
    rot = down_frame(np.array([0.0, 1.0, 0.0]))
    start = ctx.plan.solve(np.array([0.45, 0.0, 0.85]), rot, ctx.hand.q)
    assert start.ok()
    leg = Leg(np.array([0.45, 0.0, 0.85]), rot, start.qpos, TRANSIT_SPEED)
    below = np.array([0.45, 0.0, 0.80])
    assert ctx.plan.straight_line(leg, below, rot, 0.004) is not None
    assert ctx.plan.straight_line(leg, below, axis_rotation(rot[:, 2], np.pi / 2) @ rot, 0.004) is not None
    assert ctx.plan.straight_line(leg, below, rot @ FLIP, 0.004) is None


def test_the_planner_reads_the_hand_and_only_the_context_moves_it() -> None:
    """Planning is a dry run: a path over the scene and a choice among candidates leave the hand's
    planned pose, joints and what it may touch as they were; the context's moves along the path
    then bring the hand to its end, and a shared motion continues from there."""
    from pipette_cli.skills.frames import down_frame
    from pipette_cli.skills.motions import follow, lift_clear
    from pipette_cli.skills.runtime import SkillContext

    world = World(REGISTRY.get("PickUpTestTube"))
    world.reset(0)
    ctx = SkillContext(world, np.random.default_rng(0))
    hand = ctx.hand
    before = (hand.pos.copy(), hand.rot.copy(), hand.q.copy(), set(hand.allowed))
    goal = world.position("tube") + np.array([0.0, 0.0, 0.25])
    rot = down_frame(np.array([0.0, 1.0, 0.0]))
    legs = ctx.plan.path(goal, rot)
    far = goal + np.array([5.0, 0.0, 0.0])  # out of every arm's reach
    chosen = ctx.plan.choose([far, goal], lambda p: [(p, rot)])
    assert legs and chosen is goal
    assert ctx.plan.path(far, rot) is None and not ctx.plan.can_reach(far, rot)
    np.testing.assert_array_equal(hand.pos, before[0])
    np.testing.assert_array_equal(hand.rot, before[1])
    np.testing.assert_array_equal(hand.q, before[2])
    assert hand.allowed == before[3]

    moves = list(follow(ctx, legs))
    assert len(moves) == len(legs) and np.linalg.norm(hand.pos - goal) < 0.015
    np.testing.assert_array_equal(hand.q, legs[-1].q)
    assert moves[-1].q is hand.q
    height = float(hand.pos[2])
    lifted = list(lift_clear(ctx, 0.05))
    assert lifted and hand.pos[2] == pytest.approx(height + 0.05)


def test_a_held_tube_is_carried_straight_where_the_arc_would_swing_it() -> None:
    """VortexConicalTube seed 10: the 50 mL tube's way from the bench to over the vortex mixer (30 cm
    sideways at its height) has no joint-space arc that keeps it level (the arcs sag or turn it), so
    the planner had found no path ('the move: no path to ...'). Carried along straight lines instead,
    it stays level, in the fingers, and the protocol completes."""
    world = World(REGISTRY.get("protocols/VortexConicalTube-v1"))
    world.reset(10)
    expert = ProgramExpert(list(world.task.expert or []))
    expert.reset(world, np.random.default_rng([10, 1]))
    heights, offsets = [], []
    while not world.verdict.done and not expert.failure:
        world.step(expert.act(world))
        if expert.step_index == 1:  # the move to over the cup
            heights.append(world.tcp_position()[2])
            offsets.append(world.tcp_rotation().T @ (world.position("tube") - world.tcp_position()))
    assert expert.failure is None, expert.failure
    assert world.verdict.success, world.verdict
    assert min(heights) > min(heights[0], heights[-1]) - 0.02  # no sag on the way
    assert np.ptp(np.array(offsets), axis=0).max() < 0.005  # nor a slip in the fingers


def drafted_world(text: str) -> World:
    from pipette_cli.authoring.backends import make_backend
    from pipette_cli.authoring.workflow import draft_task

    return World(draft_task(text, make_backend("offline")).spec)


@pytest.mark.parametrize(
    ("text", "name"),
    [("Pick up the glass stirring rod", "rod"), ("Pick up the spatula", "spatula")],  # 6 mm round, 3 mm flat
)
@pytest.mark.parametrize("seed", [0, 1])
def test_a_tool_lying_low_is_taken_with_the_fingertips_touched_down(text: str, name: str, seed: int) -> None:
    """Servos sagging onto the bench pressed the fingertips on it at 50-80 N and friction held them
    open (seeds 0 and 1 of both failed); stopped short, the pads close above a rod's middle and
    squeeze it out. The hand goes down in steps until a fingertip touches, lightly."""
    from pipette_cli.demos.check import run_expert_episode

    world = drafted_world(text)
    pressed: list[float] = []
    bench = {b for b in range(world.model.nbody) if world.model.body(b).name.startswith("bench/")}
    original = world.step

    def step(action):
        verdict = original(action)
        if action[-1] < 0.5 and not world.robot_touches(name):  # closing, not yet on the tool
            pressed.append(world.robot_force(bench))
        return verdict

    world.step = step  # type: ignore[method-assign]
    verdict, failure = run_expert_episode(world, seed)
    assert verdict.success, failure or verdict.reason
    assert max(pressed, default=0.0) < 20.0, f"the fingertips pressed the bench at {max(pressed):.0f} N"


def test_a_lift_off_lid_is_put_back_on_its_seat_from_beside_and_after_lifting_it_off() -> None:
    from pipette_cli.demos.check import run_expert_episode

    for text in ("Put the lid back on the water bath", "Lift the lid off the water bath, then put it back"):
        world = drafted_world(text)
        verdict, failure = run_expert_episode(world, 0)
        assert verdict.success, f"{text}: {failure or verdict.reason}"
        assert upright(world, "lid") < 5.0


@pytest.mark.parametrize("seed", [0, 1])
def test_a_dish_pinched_at_its_rim_is_set_down_level(seed: int) -> None:
    """The pinch lifts the dish's near side (3-9 deg in the hand); set down as held it landed on its
    edge and tipped past 15 deg (seeds 0 and 1 failed 'tilted'). The hand now turns it level first."""
    from pipette_cli.demos.check import run_expert_episode

    world = drafted_world("Put the petri dish right of the hot plate")
    verdict, failure = run_expert_episode(world, seed)
    assert verdict.success, failure or verdict.reason
    assert upright(world, "dish") < 3.0


def test_an_object_is_let_go_with_the_fingertips_off_what_it_is_set_on() -> None:
    """The arm sags 5 mm below its plan over the 90 mm dish; the fingertips, level with the small
    dish's base, pressed the big one into the bench (6.6-10.4 N as they opened, seeds 0, 2, 3), and
    opening flung the small one off where the press was harder. Before the fingers open, a hand that
    touches more than what it sets down is raised to its plan."""
    from pipette_cli.demos.check import run_expert_episode

    world = drafted_world("Put the 35 mm petri dish on the 90 mm petri dish")
    below = {b for b in range(world.model.nbody) if world.model.body(b).name.startswith("dish_2/")}
    pressed: list[float] = []
    closed = [False]
    original = world.step

    def step(action):
        closed[0] = closed[0] or action[-1] < 0.5
        if action[-1] >= 0.5 and closed[0] and not pressed:  # the fingers open on the dish they carried
            pressed.append(world.robot_force(below))
        return original(action)

    world.step = step  # type: ignore[method-assign]
    verdict, failure = run_expert_episode(world, 0)
    assert verdict.success, failure or verdict.reason
    assert pressed and pressed[0] < 1.0, f"the fingers pressed the dish under it at {pressed[0]:.1f} N"
    assert upright(world, "dish") < 5.0


@pytest.mark.parametrize(
    ("text", "name"),
    # a 3 g plastic cuvette (12.5 mm square) and a 16 x 150 mm glass test tube
    [("Pick up the cuvette", "cuvette"), ("Pick up the 16 x 150 mm test tube", "tube")],
)
def test_a_light_object_is_held_by_fingers_that_close_without_bouncing(text: str, name: str) -> None:
    """With the finger servo chattering at its force limit, the fingers bounced off a 3 g cuvette and
    stopped 19 mm open (2 of 5 seeds failed the gate): closed on it, they stay closed on it."""
    from pipette_cli.demos.check import run_expert_episode

    world = drafted_world(text)
    for seed in (0, 1, 2):
        verdict, failure = run_expert_episode(world, seed, 900)
        assert failure is None and verdict.success, (seed, failure, verdict.reason)
