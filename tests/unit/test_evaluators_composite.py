"""Composite evaluators: ``all`` at the same time, ``any`` first success, ``sequence`` in order.

Step ``k`` (1-based) is ``verdicts[k - 1]``; control at 30 Hz.
"""

from __future__ import annotations

from pytest import approx

from pipette_cli.evaluators import make_evaluator
from pipette_cli.evaluators.base import Evaluator
from pipette_cli.evaluators.testing import ScriptedWorld, first_done, rotation_x, run
from pipette_cli.specs.evaluators import AllOfSpec, AnyOfSpec, EvaluatorSpec, RegionHoldSpec, SequenceSpec

LID = {"type": "joint_threshold", "joint": "box/lid_hinge", "bound": {"min": 80}, "hold_s": 0.1}  # 3 steps
LIFT = {"type": "lift_and_hold", "object": "tube", "min_height_gain": 0.02, "hold_s": 0.2, "max_tilt_deg": 30}  # 6


def world() -> ScriptedWorld:
    return ScriptedWorld(positions={"tube": (0.5, 0.0, 0.6)}, joints={"box/lid_hinge": 0.0})


def started(spec: EvaluatorSpec, w: ScriptedWorld) -> Evaluator:
    evaluator = make_evaluator(spec)
    evaluator.reset(w)
    return evaluator


def lid_open(steps: set[int] | None = None, from_step: int = 1):
    """Lid open (90 deg) on the given steps, or from ``from_step`` on."""

    def script(w: ScriptedWorld, k: int) -> None:
        is_open = k in steps if steps is not None else k >= from_step
        w.joints["box/lid_hinge"] = 90.0 if is_open else 0.0

    return script


def tube_up(from_step: int = 1, dy: float = 0.0):
    def script(w: ScriptedWorld, k: int) -> None:
        if k >= from_step:
            w.move("tube", (0.5, dy, 0.63))

    return script


def both(*scripts):
    def script(w: ScriptedWorld, k: int) -> None:
        for s in scripts:
            s(w, k)

    return script


# --- all ----------------------------------------------------------------------------------------


def test_all_needs_every_child_satisfied_at_the_same_time() -> None:
    w = world()
    spec = AllOfSpec(of=[LID, LIFT])
    # Lid holds 3 steps (done at 3), slams at 5, reopens at 6; the tube is up from 1 (done at 6).
    # Latched children would succeed at 6; at the same time needs the lid's hold again: 6, 7, 8.
    verdicts = run(started(spec, w), w, 20, both(lid_open(steps={1, 2, 3, 4} | set(range(6, 21))), tube_up()))
    assert verdicts[2].metrics["satisfied"] == 1.0  # the lid alone
    assert verdicts[5].metrics["satisfied"] == 1.0  # the tube alone; the lid holds again
    assert first_done(verdicts) == 8 and verdicts[7].success
    assert verdicts[7].metrics["satisfied"] == 2.0
    assert verdicts[7].metrics["0.joint_deg"] == 90.0 and verdicts[7].metrics["1.height_gain"] == approx(0.03)
    assert verdicts[7].metrics["0.hold_s"] == approx(3 / 30) and verdicts[7].metrics["1.hold_s"] == approx(8 / 30)


def test_all_fails_with_the_failing_childs_reason() -> None:
    w = world()

    def tip_at_4(w: ScriptedWorld, k: int) -> None:
        w.rotations["tube"] = rotation_x(45.0 if k >= 4 else 0.0)

    verdicts = run(started(AllOfSpec(of=[LID, LIFT]), w), w, 10, both(lid_open(), tip_at_4))
    assert first_done(verdicts) == 4 and verdicts[3].failed and verdicts[3].reason == "tilted"


def test_composite_timeout_applies_on_top_and_names_the_unmet_child() -> None:
    w = world()
    spec = AllOfSpec(of=[LID, LIFT], timeout_s=1.0)
    verdicts = run(started(spec, w), w, 40, lid_open())
    assert first_done(verdicts) == 30
    assert verdicts[29].failed and verdicts[29].reason == "not_lifted"
    assert verdicts[29].metrics["timed_out"] == 1.0


def test_child_timeout_fails_the_all() -> None:
    w = world()
    spec = AllOfSpec(of=[LID, {**LIFT, "timeout_s": 0.5}])
    verdicts = run(started(spec, w), w, 40, lid_open())
    assert first_done(verdicts) == 15 and verdicts[14].reason == "not_lifted"


def test_a_satisfied_child_does_not_time_out_inside_all() -> None:
    w = world()
    spec = AllOfSpec(of=[{**LID, "timeout_s": 0.5}, LIFT])
    # The lid meets its 0.5 s deadline at step 3, is shut on steps 10..20 (past the deadline)
    # and reopens; the tube comes up at step 20: both are satisfied at 25.
    lid = lid_open(steps=set(range(1, 10)) | set(range(21, 41)))
    verdicts = run(started(spec, w), w, 40, both(lid, tube_up(from_step=20)))
    assert verdicts[15].metrics["0.hold_s"] == 0.0 and not verdicts[15].done
    assert first_done(verdicts) == 25 and verdicts[24].success


# --- any ----------------------------------------------------------------------------------------


def test_any_succeeds_with_the_first_child() -> None:
    w = world()
    verdicts = run(started(AnyOfSpec(of=[LIFT, LID]), w), w, 20, lid_open(from_step=5))
    assert first_done(verdicts) == 7 and verdicts[6].success  # the lid: 5, 6, 7
    assert verdicts[6].metrics["satisfied"] == 1.0


def test_any_fails_only_when_every_child_failed() -> None:
    w = world()
    spec = AnyOfSpec(of=[{**LIFT, "timeout_s": 0.5}, {**LID, "timeout_s": 1.0}])
    verdicts = run(started(spec, w), w, 40)
    assert not verdicts[14].done  # the lift failed, the lid may still open
    assert first_done(verdicts) == 30
    assert verdicts[29].failed and verdicts[29].reason == "not_lifted"  # the first child's reason


def test_any_ignores_a_failed_child_once_another_succeeds() -> None:
    w = world()
    spec = AnyOfSpec(of=[{**LIFT, "timeout_s": 0.2}, LID])
    verdicts = run(started(spec, w), w, 20, lid_open(from_step=8))
    assert first_done(verdicts) == 10 and verdicts[9].success


# --- sequence -----------------------------------------------------------------------------------


def test_sequence_checks_a_stage_only_after_the_previous_one() -> None:
    w = world()
    quick_lid = {**LID, "hold_s": 0.0}
    quick_lift = {**LIFT, "hold_s": 0.0}
    spec = SequenceSpec(of=[quick_lift, quick_lid])
    # The lid is open all along; the tube comes up at 5: stage 0 done at 5, stage 1 first
    # checked (and satisfied) at 6.
    verdicts = run(started(spec, w), w, 10, both(lid_open(), tube_up(from_step=5)))
    assert verdicts[3].metrics["stage"] == 0.0 and "1.joint_deg" not in verdicts[3].metrics
    assert verdicts[4].metrics["stage"] == 1.0 and not verdicts[4].done
    assert first_done(verdicts) == 6 and verdicts[5].success
    assert verdicts[5].metrics["stage"] == 2.0
    assert {v.metrics["stages"] for v in verdicts[:6]} == {2.0}  # progress = stage / stages


def test_sequence_stage_references_start_with_the_stage() -> None:
    w = world()
    moved = {"type": "displacement", "object": "tube", "delta": {"y": {"min": 0.1}}, "hold_s": 0.0}
    spec = SequenceSpec(of=[LIFT, moved])

    def path(w: ScriptedWorld, k: int) -> None:
        w.move("tube", (0.5, 0.15 if k < 20 else 0.3, 0.63))  # carried 0.15 m aside while lifting

    verdicts = run(started(spec, w), w, 30, path)
    assert verdicts[5].metrics["stage"] == 1.0  # lift held 6 steps
    assert verdicts[6].metrics["1.dy"] == approx(0.0)  # measured from where stage 1 began
    assert first_done(verdicts) == 20 and verdicts[19].success


def test_sequence_stage_timeout_counts_from_the_stage_start() -> None:
    w = world()
    spec = SequenceSpec(of=[{**LID, "hold_s": 0.0}, {**LIFT, "timeout_s": 0.5}])
    verdicts = run(started(spec, w), w, 60, lid_open(from_step=20))
    assert first_done(verdicts) == 35  # stage 1 starts at 20, fails 15 steps later
    assert verdicts[34].failed and verdicts[34].reason == "not_lifted"


def test_sequence_fails_on_the_current_stage_failure_and_latches() -> None:
    w = world()
    spec = SequenceSpec(of=[{**LID, "hold_s": 0.0}, LIFT])

    def tip_at_3(w: ScriptedWorld, k: int) -> None:
        w.rotations["tube"] = rotation_x(60.0 if k == 3 else 0.0)

    evaluator = started(spec, w)
    verdicts = run(evaluator, w, 10, both(lid_open(), tube_up(), tip_at_3))
    assert first_done(verdicts) == 3 and verdicts[2].reason == "tilted"
    assert all(v is verdicts[2] for v in verdicts[2:])


def test_nested_composites() -> None:
    w = world()
    spec = AllOfSpec.model_validate({"type": "all", "of": [{"type": "any", "of": [LIFT, LID]}, {**LID, "hold_s": 0.2}]})
    verdicts = run(started(spec, w), w, 20, lid_open(from_step=2))
    assert first_done(verdicts) == 7  # inner any at 4 (lid 2..4), outer lid child 2..7
    assert verdicts[6].metrics["0.1.joint_deg"] == 90.0


SEATED = {
    "type": "region_hold",
    "object": "tube",
    "z": {"min": 0.59, "max": 0.61},
    "max_tilt_deg": 5.0,
    "released": True,
    "hold_s": 0.0,
}


def test_sequence_takes_upright_from_the_episode_start_not_the_stage_start() -> None:
    # stage 0 leaves the object tilted 20 deg in the hand; stage 1 wants it set back level: level
    # is how it stood as the episode began, so set down level it succeeds, set down as held it fails
    def carried_then(level: bool):
        def script(w: ScriptedWorld, k: int) -> None:
            w.touched = {"tube"} if k < 10 else set()
            w.move("tube", (0.5, 0.0, 0.63 if k < 8 else 0.6))
            w.rotations["tube"] = rotation_x(0.0 if level and k >= 8 else 20.0)

        return script

    spec = SequenceSpec(of=[{**LIFT, "hold_s": 0.0}, SEATED])
    w = world()
    verdicts = run(started(spec, w), w, 15, carried_then(level=True))
    assert first_done(verdicts) == 10 and verdicts[9].success
    w = world()
    verdicts = run(started(spec, w), w, 15, carried_then(level=False))
    assert first_done(verdicts) == 10 and verdicts[9].reason == "tilted"


def test_a_released_placement_carried_tilted_is_held_not_failed() -> None:
    w = world()
    evaluator = started(RegionHoldSpec(**SEATED), w)
    w.touched = {"tube"}
    w.rotations["tube"] = rotation_x(30.0)
    verdicts = run(evaluator, w, 5)
    assert first_done(verdicts) is None and evaluator.unmet == "held"
    w.touched = set()  # let go tilted: fallen
    assert run(evaluator, w, 1)[0].reason == "tilted"
