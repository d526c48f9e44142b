"""``--check``: trivial tasks and unstable layouts are caught; the task's expert program is run."""

from __future__ import annotations

import numpy as np
import pytest

from pipette_cli.authoring.backends import make_backend
from pipette_cli.authoring.workflow import draft_task
from pipette_cli.demos.experts import base as experts
from pipette_cli.specs.task import TaskSpec
from pipette_cli.taskgen.check import SolveReport, check_task, failure_class, solve_check

TEXT = "Put the 90 mm petri dish on the orbital shaker"


@pytest.fixture(scope="module")
def dish_task() -> TaskSpec:
    return draft_task(TEXT, make_backend("offline")).spec


def with_changes(spec: TaskSpec, success: dict | None = None, lift: float = 0.0) -> TaskSpec:
    data = spec.model_dump(mode="json")
    if success is not None:
        data["success"] = success
    if lift:
        dish = next(o for o in data["scene"]["objects"] if o["name"] == "dish")
        dish["pose"]["pos"][2] += lift
    return TaskSpec.model_validate(data)


class StandStill:
    def reset(self, world, rng) -> None:
        self.action = np.append(np.asarray(world.task.embodiment.initial_joints, dtype=float), 1.0)

    def act(self, world) -> np.ndarray:
        return self.action


@pytest.fixture
def no_program(monkeypatch, dish_task):
    """The drafted task without an expert program, and none derivable from its criterion."""
    from pipette_cli.skills import derive

    monkeypatch.delitem(derive.DERIVERS._items, dish_task.success.type)
    return dish_task.model_copy(update={"expert": None})


def test_a_drafted_task_passes_the_idle_checks(no_program) -> None:
    report = check_task(no_program, episodes=2)
    assert report.ok, report.problems
    assert report.idle_steps >= 2 * 15 * 30  # the whole 15 s time limit was rolled out, twice
    assert report.max_drift_m < 0.005
    assert report.solve.status == "not_checked" and "no expert program can be read off" in report.solve.summary()


def test_a_task_solved_by_doing_nothing_is_refused(dish_task) -> None:
    trivial = with_changes(
        dish_task, {"type": "region_hold", "object": "dish", "z": {"min": 0.5}, "hold_s": 0.5, "timeout_s": 5}
    )
    report = check_task(trivial, episodes=1, solve=False)
    assert not report.ok and "the task is trivial" in report.problems[0]


def test_an_object_that_does_not_rest_is_reported(dish_task) -> None:
    floating = with_changes(dish_task, lift=0.3)  # starts 30 cm in the air and falls
    report = check_task(floating, episodes=1, solve=False)
    assert any("dish moved" in p for p in report.problems) and report.max_drift_m > 0.05


def test_solve_check_runs_the_tasks_expert(dish_task, monkeypatch) -> None:
    monkeypatch.setitem(experts._CUSTOM, dish_task.id.rsplit("-v", 1)[0], StandStill)
    report = solve_check(dish_task, episodes=2)
    assert report.status == "unsolved" and report.expert.endswith("StandStill") and report.successes == 0
    assert report.reasons == [
        "seed 0: the criterion not met; evaluator: out_of_region",
        "seed 1: the criterion not met; evaluator: out_of_region",
    ]
    assert "seeds 0, 1: the criterion not met" in report.summary()
    assert report.classes == {"evaluator: out_of_region": [0, 1]}
    easy = with_changes(
        dish_task, {"type": "region_hold", "object": "dish", "z": {"min": 0.5}, "hold_s": 0.2, "timeout_s": 3}
    )
    solved = solve_check(easy, episodes=2)
    assert solved.status == "solved" and solved.successes == 2


def test_a_failure_is_named_by_a_class_free_of_objects_and_numbers() -> None:
    """The development set's failures are counted by class (benchmarks/bench_new_task.py): the
    skill and why it stopped, whatever object, place or distance, or the criterion's reason."""
    pick = [
        "step 1 (pick dish): the grasp on 'dish' did not hold (it is 353 mm from where it was held)",
        "step 2 (pick tube): the grasp on 'tube' did not hold (it is 75 mm from where it was held)",
    ]
    assert {failure_class(f, None) for f in pick} == {"pick: the grasp on X did not hold"}
    line_up = (
        "step 4 (insert_into tube): lining 'tube' up with 'rack/slot_9' (0.464, 0.299, 0.576): no straight "
        "way there for the franka_panda that touches nothing but what it works on (it would hit bench/base)"
    )
    assert failure_class(line_up, None) == (
        "insert_into: no straight way there for the franka_panda that touches nothing but what it works on"
    )
    assert failure_class(None, "tilted") == "evaluator: tilted"
    assert failure_class(None, None) == "evaluator: not done"


def test_four_of_five_seeds_pass_the_gate() -> None:
    assert SolveReport("unsolved", episodes=5).required == 4
    assert SolveReport("unsolved", episodes=2).required == 2


def test_a_failed_sequence_names_the_stage_it_stopped_at(monkeypatch) -> None:
    drafted = draft_task("Open the thermal cycler, then close it", make_backend("offline"))
    spec = drafted.spec
    assert drafted.composed.stage_names == ["open the thermal cycler", "close the thermal cycler"]
    monkeypatch.setitem(experts._CUSTOM, spec.id.rsplit("-v", 1)[0], StandStill)
    report = solve_check(spec, 1, drafted.composed.stage_names)
    assert report.reasons == ["seed 0: stage 1 of 2 (open the thermal cycler) not met; evaluator: not_reached"]
