"""Primitive success evaluators on scripted trajectories, with the registry's (paper A.8) numbers.

Conventions: control at 30 Hz; step ``k`` (1-based) happens at ``t = k / 30`` and is
``verdicts[k - 1]``; a hold of ``h`` seconds needs ``ceil(h * 30)`` consecutive steps.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pytest import approx

from pipette_cli.evaluators import MechanismState, Verdict, make_evaluator
from pipette_cli.evaluators.base import Evaluator
from pipette_cli.evaluators.testing import ScriptedWorld, first_done, rotation_x, run
from pipette_cli.specs.evaluators import (
    EvaluatorSpec,
    JointThresholdSpec,
    LiftAndHoldSpec,
    NearTargetSpec,
    RegionHoldSpec,
)
from pipette_cli.specs.task import TaskSpec
from pipette_cli.specs.yaml_io import read_yaml, to_plain

REGISTRY = Path(__file__).resolve().parents[2] / "registry"


def task_success(stem: str) -> EvaluatorSpec:
    """The success spec of a registry task, read from its YAML (assets not needed)."""
    doc = to_plain(read_yaml(REGISTRY / f"{stem}.yaml"))
    return TaskSpec.model_validate(doc, context={"defer_references": True}).success


def started(spec: EvaluatorSpec, world: ScriptedWorld) -> Evaluator:
    evaluator = make_evaluator(spec)
    evaluator.reset(world)
    return evaluator


def not_done_before(verdicts: list[Verdict], step: int) -> bool:
    return not any(v.done for v in verdicts[: step - 1])


# --- lift_and_hold (pick up the test tube: 0.02 m, 0.5 s, 35 deg, 7 s) --------------------

Z0 = 0.6


def tube_world() -> ScriptedWorld:
    return ScriptedWorld(positions={"tube": (0.5, 0.0, Z0)})


def lifted_from(start: int, gain: float = 0.03):
    def script(world: ScriptedWorld, k: int) -> None:
        world.move("tube", (0.5, 0.0, Z0 + (gain if k >= start else 0.0)))

    return script


def test_tube_spec_has_the_paper_numbers() -> None:
    spec = task_success("pick_up_test_tube")
    assert isinstance(spec, LiftAndHoldSpec)
    assert (spec.min_height_gain, spec.hold_s, spec.max_tilt_deg, spec.timeout_s) == (0.02, 0.5, 35, 7)


def test_lift_succeeds_after_exactly_the_hold() -> None:
    world = tube_world()
    verdicts = run(started(task_success("pick_up_test_tube"), world), world, 40, lifted_from(5))
    assert first_done(verdicts) == 19  # steps 5..19: 15 x 1/30 s = 0.5 s
    assert verdicts[18].success and not verdicts[18].failed
    assert verdicts[17].metrics["hold_s"] == approx(14 / 30)
    assert verdicts[3].metrics["hold_s"] == 0.0 and verdicts[3].metrics["height_gain"] == approx(0.0)
    assert verdicts[18].metrics["height_gain"] == approx(0.03)
    assert verdicts[18].metrics["tilt_deg"] == approx(0.0, abs=1e-6)


def test_lift_hold_restarts_when_interrupted() -> None:
    world = tube_world()

    def dip_at_10(w: ScriptedWorld, k: int) -> None:
        w.move("tube", (0.5, 0.0, Z0 + (0.01 if k == 10 else 0.03)))

    verdicts = run(started(task_success("pick_up_test_tube"), world), world, 40, dip_at_10)
    assert verdicts[8].metrics["hold_s"] == approx(9 / 30)
    assert verdicts[9].metrics["hold_s"] == 0.0
    assert first_done(verdicts) == 25 and verdicts[24].success  # 11..25


def test_lift_gain_threshold_is_strict_about_the_height() -> None:
    low, high = tube_world(), tube_world()
    low_verdicts = run(started(task_success("pick_up_test_tube"), low), low, 100, lifted_from(1, 0.0199))
    high_verdicts = run(started(task_success("pick_up_test_tube"), high), high, 100, lifted_from(1, 0.0201))
    assert first_done(low_verdicts) is None
    assert first_done(high_verdicts) == 15


def test_lift_tilt_fails_at_once() -> None:
    world = tube_world()

    def tip_over(w: ScriptedWorld, k: int) -> None:
        w.rotations["tube"] = rotation_x(36.0 if k >= 3 else 0.0)

    verdicts = run(started(task_success("pick_up_test_tube"), world), world, 10, tip_over)
    assert first_done(verdicts) == 3
    assert verdicts[2].failed and verdicts[2].reason == "tilted"
    assert verdicts[2].metrics["tilt_deg"] == approx(36.0)


def test_lift_tilt_below_the_limit_still_succeeds() -> None:
    world = tube_world()

    def lift_tilted(w: ScriptedWorld, k: int) -> None:
        lifted_from(1)(w, k)
        w.rotations["tube"] = rotation_x(34.0)

    verdicts = run(started(task_success("pick_up_test_tube"), world), world, 20, lift_tilted)
    assert first_done(verdicts) == 15 and verdicts[14].success


def test_lift_tilt_is_measured_from_the_initial_axis() -> None:
    world = ScriptedWorld(positions={"tube": (0.5, 0.0, Z0)}, rotations={"tube": rotation_x(50.0)})
    verdicts = run(started(task_success("pick_up_test_tube"), world), world, 20, lifted_from(1))
    assert verdicts[0].metrics["tilt_deg"] == approx(0.0, abs=1e-6)
    assert first_done(verdicts) == 15 and verdicts[14].success


def test_lift_times_out_at_7_s_with_the_most_telling_reason() -> None:
    never = tube_world()
    verdicts = run(started(task_success("pick_up_test_tube"), never), never, 220)
    assert first_done(verdicts) == 210  # t = 7.0 s
    assert verdicts[209].failed and verdicts[209].reason == "not_lifted"
    assert verdicts[209].metrics["timed_out"] == 1.0 and "timed_out" not in verdicts[208].metrics

    dropped = tube_world()

    def drop_at_6(w: ScriptedWorld, k: int) -> None:
        w.move("tube", (0.5, 0.0, Z0 + (0.03 if k < 6 else 0.0)))

    verdicts = run(started(task_success("pick_up_test_tube"), dropped), dropped, 220, drop_at_6)
    assert first_done(verdicts) == 210 and verdicts[209].reason == "dropped"  # no early failure
    assert verdicts[209].metrics["max_height_gain"] == approx(0.03)

    late = tube_world()
    verdicts = run(started(task_success("pick_up_test_tube"), late), late, 220, lifted_from(200))
    assert first_done(verdicts) == 210 and verdicts[209].reason == "timeout"  # up, hold cut short


def test_lift_success_on_the_timeout_step_counts() -> None:
    world = tube_world()
    verdicts = run(started(task_success("pick_up_test_tube"), world), world, 220, lifted_from(196))
    assert first_done(verdicts) == 210 and verdicts[209].success


def test_verdicts_latch_after_success_and_after_failure() -> None:
    world = tube_world()
    evaluator = started(task_success("pick_up_test_tube"), world)
    verdicts = run(evaluator, world, 15, lifted_from(1))
    assert verdicts[-1].success
    world.move("tube", (0.5, 0.0, Z0))
    world.rotations["tube"] = rotation_x(90.0)
    later = run(evaluator, world, 300)
    assert all(v is verdicts[-1] for v in later)

    world = tube_world()
    evaluator = started(task_success("pick_up_test_tube"), world)
    world.rotations["tube"] = rotation_x(40.0)
    failed = run(evaluator, world, 1)[0]
    assert failed.reason == "tilted"
    world.rotations["tube"] = np.eye(3)
    assert all(v is failed for v in run(evaluator, world, 20, lifted_from(1)))


def test_zero_hold_succeeds_on_the_first_step_the_condition_holds() -> None:
    world = tube_world()
    spec = LiftAndHoldSpec(object="tube", min_height_gain=0.02, hold_s=0.0)
    verdicts = run(started(spec, world), world, 10, lifted_from(4))
    assert first_done(verdicts) == 4 and verdicts[3].success


def test_reset_starts_over_from_the_new_state() -> None:
    world = tube_world()
    evaluator = started(task_success("pick_up_test_tube"), world)
    assert run(evaluator, world, 15, lifted_from(1))[-1].success
    evaluator.reset(world)  # the tube is now 3 cm up: that is the new z_0
    verdicts = run(evaluator, world, 20)
    assert first_done(verdicts) is None and verdicts[-1].metrics["height_gain"] == approx(0.0)


# --- region_hold (tube on the balance: disc 0.5 x half the pan, 0.63 < z < 0.73, 1 s) -------

PAN = np.array([0.6, 0.1, 0.64])


def balance_world(tube: tuple[float, float, float] = (0.3, -0.1, 0.6)) -> ScriptedWorld:
    return ScriptedWorld(
        positions={"tube": tube, "balance/pan_center": PAN},
        bboxes={"balance/pan": (0.20, 0.16)},
    )


def place_at(pos: tuple[float, float, float], from_step: int = 1):
    def script(world: ScriptedWorld, k: int) -> None:
        if k >= from_step:
            world.move("tube", pos)

    return script


def test_balance_disc_radius_comes_from_the_pan_bbox() -> None:
    world = balance_world()
    verdicts = run(started(task_success("place_tube_on_balance"), world), world, 40, place_at((0.63, 0.1, 0.65)))
    assert verdicts[0].metrics["radius"] == approx(0.5 * 0.5 * 0.16)
    assert verdicts[0].metrics["xy_error"] == approx(0.03)
    assert first_done(verdicts) == 30 and verdicts[29].success  # 1 s
    assert {("bbox_xy", "balance/pan"), ("position", "balance/pan_center"), ("position", "tube")} <= world.reads


@pytest.mark.parametrize(
    ("pos", "reason"),
    [
        ((0.6 + 0.0401, 0.1, 0.65), "out_of_region"),
        ((0.6, 0.1 - 0.0401, 0.65), "out_of_region"),
        ((0.6, 0.1, 0.62), "too_low"),
        ((0.6, 0.1, 0.74), "too_high"),
        ((0.7, 0.1, 0.62), "out_of_region"),  # outside in xy and too low: xy wins
    ],
)
def test_balance_region_edges_and_timeout_reason(pos: tuple[float, float, float], reason: str) -> None:
    world = balance_world()
    verdicts = run(started(task_success("place_tube_on_balance"), world), world, 460, place_at(pos))
    assert first_done(verdicts) == 450  # 15 s
    assert verdicts[449].failed and verdicts[449].reason == reason


def test_balance_disc_edge_inside() -> None:
    world = balance_world()
    verdicts = run(
        started(task_success("place_tube_on_balance"), world), world, 40, place_at((0.6 + 0.0399, 0.1, 0.65))
    )
    assert first_done(verdicts) == 30 and verdicts[29].success


def test_region_hold_restarts_when_the_object_leaves() -> None:
    world = balance_world()

    def wobble(w: ScriptedWorld, k: int) -> None:
        w.move("tube", (0.6, 0.1, 0.65) if k != 20 else (0.7, 0.1, 0.65))

    verdicts = run(started(task_success("place_tube_on_balance"), world), world, 60, wobble)
    assert verdicts[19].metrics["hold_s"] == 0.0
    assert first_done(verdicts) == 50  # 21..50


def test_region_disc_follows_a_moving_center() -> None:
    world = balance_world()

    def pan_moves_tube_stays(w: ScriptedWorld, k: int) -> None:
        w.move("tube", (0.6, 0.1, 0.65))
        w.move("balance/pan_center", PAN + [0.002 * k, 0.0, 0.0])  # leaves the tube after 20 steps

    verdicts = run(started(task_success("place_tube_on_balance"), world), world, 100, pan_moves_tube_stays)
    assert first_done(verdicts) is None
    assert verdicts[-1].metrics["xy_error"] == approx(0.2)


def test_region_inclusive_axis_bounds_of_the_pipette_rack() -> None:
    spec = task_success("place_pipette_in_rack")  # y >= 0.14, z >= 0.58, 1 s, 30 s
    on_edge = ScriptedWorld(positions={"pipette": (0.5, 0.14, 0.62)})
    verdicts = run(started(spec, on_edge), on_edge, 40)
    assert first_done(verdicts) == 30 and verdicts[29].success
    short = ScriptedWorld(positions={"pipette": (0.5, 0.1399, 0.7)})
    limit = round(spec.timeout_s / short.control_dt)  # the task's time limit in control steps
    verdicts = run(started(spec, short), short, limit + 100)
    assert verdicts[-1].reason == "out_of_region" and first_done(verdicts) == limit
    assert verdicts[0].metrics["out_y"] == approx(0.0001) and verdicts[0].metrics["out_z"] == 0.0


def test_a_released_region_counts_only_once_the_robot_lets_go() -> None:
    # the pipette carried over the stand is inside the paper's bounds; it is placed once let go
    spec = task_success("place_pipette_in_rack")
    assert spec.released
    world = ScriptedWorld(positions={"pipette": (0.5, 0.2, 0.95)}, touched={"pipette"})

    def hung_at_step_20(w: ScriptedWorld, k: int) -> None:
        if k == 20:
            w.move("pipette", (0.5, 0.2, 0.608))
            w.touched.clear()

    verdicts = run(started(spec, world), world, 60, hung_at_step_20)
    assert verdicts[18].metrics["hold_s"] == 0.0  # carried: not yet
    assert first_done(verdicts) == 49 and verdicts[48].success  # steps 20..49 after the release
    held = ScriptedWorld(positions={"pipette": (0.5, 0.2, 0.608)}, touched={"pipette"})
    limit = round(spec.timeout_s / held.control_dt)
    verdicts = run(started(spec, held), held, limit + 100)
    assert first_done(verdicts) == limit
    assert verdicts[-1].failed and verdicts[-1].reason == "held"  # never let go: the reason says so
    assert ("robot_touches", "pipette") in held.reads
    unreleased = RegionHoldSpec(object="pipette", y={"min": 0.14}, hold_s=0)
    assert run(started(unreleased, held), held, 1)[0].success  # without it, as the paper has it


def test_region_tilt_limit_of_the_flask() -> None:
    spec = task_success("place_flask_on_shaker")  # max 15 deg
    positions = {"flask": (0.6, 0.0, 0.65), "shaker/platform_center": (0.6, 0.0, 0.62)}
    bboxes = {"shaker/platform": (0.3, 0.3)}
    leaning = ScriptedWorld(positions=positions, bboxes=bboxes, rotations={"flask": np.eye(3)})
    evaluator = started(spec, leaning)
    leaning.rotations["flask"] = rotation_x(16.0)
    verdicts = run(evaluator, leaning, 5)
    assert verdicts[0].failed and verdicts[0].reason == "tilted"
    upright = ScriptedWorld(positions=positions, bboxes=bboxes)
    evaluator = started(spec, upright)
    upright.rotations["flask"] = rotation_x(14.0)
    verdicts = run(evaluator, upright, 40)
    assert verdicts[0].metrics["radius"] == approx(0.6 * 0.15)
    assert first_done(verdicts) == 30 and verdicts[29].success


def test_region_given_radius() -> None:
    spec = RegionHoldSpec(object="tube", within={"center": "balance/pan_center", "radius": 0.05}, hold_s=0)
    world = balance_world(tube=(0.6, 0.149, 0.7))
    assert run(started(spec, world), world, 1)[0].success
    assert not any(kind == "bbox_xy" for kind, _ in world.reads)


# --- stable_placement (dish in the incubator: x > 0.55, y < 0.1, z > 0.6, dz <= 2 mm) ------


def dish_world(z0: float = 0.61) -> ScriptedWorld:
    return ScriptedWorld(positions={"dish": (0.7, 0.0, z0)})


def dish_z(z_of_k):
    def script(world: ScriptedWorld, k: int) -> None:
        world.move("dish", (0.7, 0.0, z_of_k(k)))

    return script


def test_stable_placement_waits_for_the_dish_to_settle() -> None:
    world = dish_world()
    bounce = dish_z(lambda k: 0.61 + (0.004 if k <= 10 and k % 2 else 0.0))
    verdicts = run(started(task_success("place_petri_dish_in_incubator"), world), world, 40, bounce)
    assert verdicts[9].metrics["dz"] == approx(0.004) and verdicts[9].metrics["hold_s"] == 0.0
    assert verdicts[10].metrics["dz"] == approx(0.0)
    assert first_done(verdicts) == 25 and verdicts[24].success  # 11..25


def test_stable_placement_accepts_slow_sinking_within_the_limit() -> None:
    world = dish_world(0.65)
    verdicts = run(
        started(task_success("place_petri_dish_in_incubator"), world), world, 20, dish_z(lambda k: 0.65 - 0.0019 * k)
    )
    assert verdicts[0].metrics["dz"] == approx(0.0019)
    assert first_done(verdicts) == 15 and verdicts[14].success


def test_stable_placement_first_step_compares_with_the_reset_height() -> None:
    world = dish_world(0.7)
    verdicts = run(started(task_success("place_petri_dish_in_incubator"), world), world, 20, dish_z(lambda k: 0.61))
    assert verdicts[0].metrics["dz"] == approx(0.09) and verdicts[0].metrics["hold_s"] == 0.0
    assert first_done(verdicts) == 16


@pytest.mark.parametrize(("x", "reason"), [(0.7, "unstable"), (0.5, "out_of_region")])
def test_stable_placement_timeout_reasons(x: float, reason: str) -> None:
    world = ScriptedWorld(positions={"dish": (x, 0.0, 0.61)})

    def jitter(w: ScriptedWorld, k: int) -> None:
        w.move("dish", (x, 0.0, 0.61 + 0.003 * (k % 2)))

    verdicts = run(started(task_success("place_petri_dish_in_incubator"), world), world, 610, jitter)
    assert first_done(verdicts) == 600 and verdicts[599].reason == reason  # 20 s


# --- joint_threshold (close the centrifuge lid: angle >= -5 deg for 0.25 s) -----------------


def lid_world(angle: float = -40.0) -> ScriptedWorld:
    return ScriptedWorld(joints={"centrifuge/lid_hinge": angle})


def lid_angles(angle_of_k):
    def script(world: ScriptedWorld, k: int) -> None:
        world.joints["centrifuge/lid_hinge"] = angle_of_k(k)

    return script


def test_joint_threshold_hold_rounds_up_to_whole_steps() -> None:
    world = lid_world()
    verdicts = run(
        started(task_success("close_centrifuge_lid"), world), world, 30, lid_angles(lambda k: -30 if k < 5 else -3)
    )
    assert verdicts[10].metrics["hold_s"] == approx(7 / 30) and not verdicts[10].done  # 0.233 s < 0.25 s
    assert first_done(verdicts) == 12 and verdicts[11].success  # 8 steps = 0.267 s
    assert verdicts[0].metrics["joint_deg"] == -30 and verdicts[0].metrics["bound_gap"] == approx(25.0)
    assert verdicts[0].metrics["joint_start_deg"] == -40


def test_joint_threshold_edge_interrupt_and_timeout() -> None:
    edge = lid_world()
    verdicts = run(started(task_success("close_centrifuge_lid"), edge), edge, 20, lid_angles(lambda k: -5.0))
    assert first_done(verdicts) == 8 and verdicts[7].success

    bounce = lid_world()
    verdicts = run(
        started(task_success("close_centrifuge_lid"), bounce), bounce, 30, lid_angles(lambda k: -6 if k == 5 else 0)
    )
    assert verdicts[4].metrics["hold_s"] == 0.0 and first_done(verdicts) == 13

    stuck = lid_world()
    verdicts = run(started(task_success("close_centrifuge_lid"), stuck), stuck, 310, lid_angles(lambda k: -5.5))
    assert first_done(verdicts) == 300 and verdicts[299].reason == "not_reached"
    assert verdicts[299].metrics["bound_gap"] == approx(0.5)


def test_joint_threshold_upper_bound_and_slide_units() -> None:
    world = ScriptedWorld(joints={"spectro/lid_hinge": 6.0})
    verdicts = run(started(task_success("close_spectrophotometer_lid"), world), world, 300)
    assert not any(v.success for v in verdicts) and verdicts[-1].reason == "not_reached"

    drawer = ScriptedWorld(joints={"fridge/drawer": 0.0})
    spec = JointThresholdSpec(joint="fridge/drawer", bound={"min": 0.2}, unit="m", hold_s=0.1)
    verdicts = run(started(spec, drawer), drawer, 10, lambda w, k: w.joints.update({"fridge/drawer": 0.03 * k}))
    assert verdicts[6].metrics["joint_m"] == approx(0.21)
    assert first_done(verdicts) == 9  # 7, 8, 9


# --- displacement (tube off the balance: dy > 0.25, dz < -0.12, 1.2 s, 10 deg) -------------

TUBE_ON_PAN = (0.6, -0.1, 0.76)


def test_displacement_from_the_initial_position() -> None:
    world = ScriptedWorld(positions={"tube": TUBE_ON_PAN})
    moved = (0.6, -0.1 + 0.26, 0.76 - 0.13)
    verdicts = run(started(task_success("remove_tube_from_balance"), world), world, 50, place_at(moved, 3))
    assert verdicts[0].metrics["dy"] == approx(0.0)
    assert verdicts[2].metrics["dx"] == approx(0.0)
    assert verdicts[2].metrics["dy"] == approx(0.26) and verdicts[2].metrics["dz"] == approx(-0.13)
    assert first_done(verdicts) == 38 and verdicts[37].success  # 3..38: 36 steps = 1.2 s


def test_displacement_needs_every_axis_and_reports_the_gap() -> None:
    world = ScriptedWorld(positions={"tube": TUBE_ON_PAN})
    only_y = (0.6, -0.1 + 0.3, 0.76 - 0.05)
    verdicts = run(started(task_success("remove_tube_from_balance"), world), world, 310, place_at(only_y))
    assert verdicts[0].metrics["bound_gap"] == approx(0.07)
    assert first_done(verdicts) == 300 and verdicts[299].reason == "not_displaced"


def test_displacement_tilt_fails() -> None:
    world = ScriptedWorld(positions={"tube": TUBE_ON_PAN})
    evaluator = started(task_success("remove_tube_from_balance"), world)
    world.rotations["tube"] = rotation_x(11.0)
    verdict = run(evaluator, world, 1)[0]
    assert verdict.failed and verdict.reason == "tilted" and verdict.metrics["tilt_deg"] == approx(11.0)


def test_water_bath_lid_displacement_needs_no_rotation() -> None:
    world = ScriptedWorld(positions={"lid": (0.7, 0.0, 0.8)})
    verdicts = run(
        started(task_success("open_water_bath_lid"), world), world, 20, lambda w, k: w.move("lid", (0.39, 0.0, 0.91))
    )
    assert first_done(verdicts) == 9  # 0.3 s
    assert world.reads == {("position", "lid")}


# --- near_target (pipette over the dish: d_xy <= 0.12 m, z >= 0.6 m, 12 s) ------------------

DISH = (0.5, 0.1, 0.57)


def pipette_world() -> ScriptedWorld:
    return ScriptedWorld(positions={"pipette": (0.3, -0.2, 0.58), "dish/center": DISH})


def pipette_at(pos_of_k):
    return lambda w, k: w.move("pipette", pos_of_k(k))


def test_near_target_succeeds_on_the_first_step_near_and_high() -> None:
    world = pipette_world()
    path = pipette_at(lambda k: (0.5 + 0.119, 0.1, 0.65) if k >= 10 else (0.3, -0.2, 0.65))
    verdicts = run(started(task_success("pipette_to_petri_dish"), world), world, 20, path)
    assert verdicts[0].metrics["xy_distance"] == approx(np.hypot(0.2, 0.3))
    assert first_done(verdicts) == 10 and verdicts[9].success
    assert verdicts[9].metrics["xy_distance"] == approx(0.119) and verdicts[9].metrics["z"] == approx(0.65)


@pytest.mark.parametrize(
    ("path", "reason"),
    [
        (lambda k: (0.5, 0.1, 0.58), "too_low"),  # right over the dish, too low all along
        (lambda k: (0.5 + 0.121, 0.1, 0.7), "out_of_region"),  # high but just too far
        (lambda k: (0.5, 0.1, 0.58) if k < 50 else (0.9, 0.1, 0.7), "too_low"),  # was near but low
    ],
)
def test_near_target_timeout_reasons(path, reason: str) -> None:
    world = pipette_world()
    verdicts = run(started(task_success("pipette_to_petri_dish"), world), world, 370, pipette_at(path))
    assert first_done(verdicts) == 360  # 12 s
    assert verdicts[359].failed and verdicts[359].reason == reason


def test_near_target_min_z_is_inclusive_and_the_target_is_followed() -> None:
    world = pipette_world()
    spec = NearTargetSpec(object="pipette", target="dish/center", max_xy_distance=0.05, min_z=0.6, hold_s=0.2)

    def dish_moves(w: ScriptedWorld, k: int) -> None:
        w.move("dish/center", (0.5 + 0.01 * k, 0.1, 0.57))
        w.move("pipette", (0.5 + 0.01 * k, 0.1, 0.6))

    verdicts = run(started(spec, world), world, 10, dish_moves)
    assert first_done(verdicts) == 6 and verdicts[5].success  # 0.2 s hold


# --- mechanism_triggered (centrifuge button: triggered and min target <= -39 deg) -----------


def ramp(world: ScriptedWorld, k: int) -> None:
    target = max(-40.0, -2.0 * (k - 4)) if k >= 5 else 0.0
    world.mechanisms["lid_release"] = MechanismState(triggered=k >= 5, target=target, min_target=target)


def test_mechanism_succeeds_when_triggered_and_the_target_is_reached() -> None:
    world = ScriptedWorld(mechanisms={"lid_release": MechanismState(False, 0.0, 0.0)})
    verdicts = run(started(task_success("open_centrifuge_lid"), world), world, 40, ramp)
    assert verdicts[3].metrics["triggered"] == 0.0
    assert verdicts[22].metrics["min_target"] == -38.0 and not verdicts[22].done
    assert first_done(verdicts) == 24 and verdicts[23].success
    assert verdicts[23].metrics["triggered"] == 1.0 and verdicts[23].metrics["bound_gap"] == 0.0
    assert ("mechanism", "lid_release") in world.reads


@pytest.mark.parametrize(
    ("state", "reason"),
    [(MechanismState(False, -45.0, -45.0), "not_triggered"), (MechanismState(True, -30.0, -30.0), "not_reached")],
)
def test_mechanism_timeout_reasons(state: MechanismState, reason: str) -> None:
    world = ScriptedWorld(mechanisms={"lid_release": state})
    verdicts = run(started(task_success("open_centrifuge_lid"), world), world, 310)
    assert first_done(verdicts) == 300 and verdicts[299].reason == reason
