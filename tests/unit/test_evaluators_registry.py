"""Evaluator registration and contract: every spec family has a runtime, unknown types are
errors, third-party families plug in without editing a list, every registry task answers."""

from __future__ import annotations

import inspect
import math
from pathlib import Path
from typing import Literal

import pytest

import pipette_cli.specs.evaluators as spec_module
from pipette_cli.errors import EvaluatorError
from pipette_cli.evaluators import Verdict, WorldState, make_evaluator, register, registered_types
from pipette_cli.evaluators.condition import Check, ConditionEvaluator
from pipette_cli.evaluators.lift import LiftAndHold
from pipette_cli.evaluators.testing import ScriptedWorld, first_done, run
from pipette_cli.specs import TaskSpec, register_evaluator
from pipette_cli.specs.evaluators import AllOfSpec, EvaluatorSpec, JointThresholdSpec, LiftAndHoldSpec
from pipette_cli.specs.yaml_io import read_yaml, to_plain

REGISTRY = Path(__file__).resolve().parents[2] / "registry"
TASK_FILES = sorted(REGISTRY.glob("*.yaml"))
BUILTIN_SPECS = [
    cls
    for _, cls in inspect.getmembers(spec_module, inspect.isclass)
    if issubclass(cls, EvaluatorSpec)
    and cls.__module__ == spec_module.__name__
    and "type" in inspect.get_annotations(cls)
]


def load_task(path: Path) -> TaskSpec:
    return TaskSpec.model_validate(to_plain(read_yaml(path)), context={"defer_references": True})


# --- registration ---------------------------------------------------------------------------------


def test_every_builtin_family_is_found() -> None:
    names = {cls.model_fields["type"].default for cls in BUILTIN_SPECS}
    assert names == {
        "lift_and_hold", "region_hold", "stable_placement", "joint_threshold", "displacement",
        "near_target", "mechanism_triggered", "instrument_state", "all", "any", "sequence",
    }  # fmt: skip
    assert names <= set(registered_types())


@pytest.mark.parametrize("spec_cls", BUILTIN_SPECS, ids=lambda cls: cls.model_fields["type"].default)
def test_runtime_rejects_a_spec_of_another_family(spec_cls: type[EvaluatorSpec]) -> None:
    other = JointThresholdSpec(joint="box/lid", bound={"min": 1.0})
    if spec_cls is JointThresholdSpec:
        other = LiftAndHoldSpec(object="tube", min_height_gain=0.1)
    runtime = type(make_evaluator(_minimal(spec_cls)))
    with pytest.raises(EvaluatorError, match="needs a"):
        runtime(other)


def _minimal(spec_cls: type[EvaluatorSpec]) -> EvaluatorSpec:
    lift = {"type": "lift_and_hold", "object": "tube", "min_height_gain": 0.1}
    examples = {
        "lift_and_hold": lift,
        "region_hold": {"object": "tube", "z": {"min": 0.6}},
        "stable_placement": {"object": "tube", "z": {"min": 0.6}},
        "joint_threshold": {"joint": "box/lid", "bound": {"min": 1.0}},
        "displacement": {"object": "tube", "delta": {"x": {"min": 0.1}}},
        "near_target": {"object": "tube", "target": "rack", "max_xy_distance": 0.1},
        "mechanism_triggered": {"mechanism": "button", "target": {"max": -39}},
        "instrument_state": {"mechanism": "centrifuge", "values": {"running": {"min": 1}}},
    }
    name = spec_cls.model_fields["type"].default
    return spec_cls.model_validate(examples.get(name, {"of": [lift]}))


def test_unknown_type_is_an_error_with_a_suggestion() -> None:
    with pytest.raises(EvaluatorError, match="unknown evaluator runtime 'lift_and_hol'; did you mean 'lift_and_hold'"):
        make_evaluator(EvaluatorSpec(type="lift_and_hol"))


def test_a_spec_without_runtime_inside_a_composite_is_an_error() -> None:
    @register_evaluator
    class HalfDoneSpec(EvaluatorSpec):
        type: Literal["test_half_done_no_runtime"] = "test_half_done_no_runtime"

    with pytest.raises(EvaluatorError, match="test_half_done_no_runtime"):
        make_evaluator(AllOfSpec.model_validate({"type": "all", "of": [{"type": "test_half_done_no_runtime"}]}))


def test_registering_another_runtime_under_a_taken_name_is_an_error() -> None:
    with pytest.raises(EvaluatorError, match="defined twice"):
        register("lift_and_hold")(lambda spec: LiftAndHold(spec))
    assert register("lift_and_hold")(LiftAndHold) is LiftAndHold  # the same one again is fine


def test_update_before_reset_is_an_error() -> None:
    evaluator = make_evaluator(LiftAndHoldSpec(object="tube", min_height_gain=0.02))
    with pytest.raises(EvaluatorError, match="reset"):
        evaluator.update(ScriptedWorld(positions={"tube": (0, 0, 0)}))


def test_unknown_ref_in_the_scripted_world_is_an_error() -> None:
    evaluator = make_evaluator(LiftAndHoldSpec(object="tueb", min_height_gain=0.02))
    with pytest.raises(EvaluatorError, match="did you mean 'tube'"):
        evaluator.reset(ScriptedWorld(positions={"tube": (0, 0, 0)}))


# --- a third-party family, registered here without editing any list --------------------------------


@register_evaluator
class PouredSpec(EvaluatorSpec):
    type: Literal["test_poured"] = "test_poured"
    object: str
    min_tilt_deg: float


@register("test_poured")
class Poured:
    """Implements only the protocol (no ConditionEvaluator): poured once the bottle tips."""

    def __init__(self, spec: PouredSpec) -> None:
        self.spec = spec
        self._final: Verdict | None = None

    def reset(self, state: WorldState) -> None:
        self._final = None

    def update(self, state: WorldState) -> Verdict:
        if self._final is not None:
            return self._final
        tipped = float(state.rotation(self.spec.object)[2, 2]) < math.cos(math.radians(self.spec.min_tilt_deg))
        verdict = Verdict(success=tipped, metrics={"cos": float(state.rotation(self.spec.object)[2, 2])})
        self._final = verdict if tipped else None
        return verdict


@register_evaluator
class AboveSpec(EvaluatorSpec):
    type: Literal["test_above"] = "test_above"
    object: str
    z: float
    hold_s: float = 0.1


@register("test_above")
class Above(ConditionEvaluator[AboveSpec]):
    """The short route: subclass ConditionEvaluator and get hold, timeout and latching."""

    spec_type = AboveSpec

    def start(self, state: WorldState) -> None:
        pass

    def check(self, state: WorldState) -> Check:
        z = float(state.position(self.spec.object)[2])
        return Check(z > self.spec.z, {"z": z}, unmet="too_low")


def test_third_party_families_work_alone_and_inside_composites() -> None:
    from pipette_cli.evaluators.testing import rotation_x

    assert {"test_poured", "test_above"} <= set(registered_types())
    spec = AllOfSpec.model_validate(
        {
            "type": "all",
            "timeout_s": 2.0,
            "of": [
                {"type": "test_poured", "object": "bottle", "min_tilt_deg": 60},
                {"type": "test_above", "object": "bottle", "z": 0.7},
            ],
        }
    )
    world = ScriptedWorld(positions={"bottle": (0.5, 0.0, 0.6)})
    evaluator = make_evaluator(spec)
    evaluator.reset(world)

    def pour_then_raise(w: ScriptedWorld, k: int) -> None:
        w.rotations["bottle"] = rotation_x(90.0 if k == 2 else 0.0)  # poured at 2, latched
        w.move("bottle", (0.5, 0.0, 0.75 if k >= 5 else 0.6))

    verdicts = run(evaluator, world, 20, pour_then_raise)
    assert verdicts[1].metrics["0.cos"] == pytest.approx(0.0, abs=1e-9)
    assert first_done(verdicts) == 7 and verdicts[6].success  # above 5, 6, 7 (0.1 s)

    world = ScriptedWorld(positions={"bottle": (0.5, 0.0, 0.6)})
    evaluator.reset(world)
    verdicts = run(evaluator, world, 70)
    assert first_done(verdicts) == 60 and verdicts[59].reason == "timeout"  # Poured gives no reason

    world = ScriptedWorld(positions={"bottle": (0.5, 0.0, 0.6)})
    evaluator.reset(world)
    verdicts = run(
        evaluator, world, 70, lambda w, k: w.rotations.update({"bottle": rotation_x(90.0 if k == 2 else 0.0)})
    )
    assert first_done(verdicts) == 60 and verdicts[59].reason == "too_low"  # poured; Above says why


# --- contract over every registry task ------------------------------------------------------------


@pytest.mark.parametrize("path", TASK_FILES, ids=lambda p: p.stem)
def test_every_registry_task_evaluator_answers_and_ends(path: Path) -> None:
    task = load_task(path)
    spec = task.success
    assert spec.timeout_s is not None, "every registry task needs a time limit"
    steps = math.ceil(spec.timeout_s * task.timing.control_hz) + 5

    def rollout() -> tuple[list[Verdict], set[tuple[str, str]]]:
        world = ScriptedWorld(strict=False, control_dt=1.0 / task.timing.control_hz)
        evaluator = make_evaluator(spec)
        evaluator.reset(world)
        return run(evaluator, world, steps), world.reads

    verdicts, reads = rollout()
    assert verdicts[0].metrics and all(math.isfinite(v) for v in verdicts[0].metrics.values())
    assert first_done(verdicts) is not None and first_done(verdicts) <= steps - 5
    assert verdicts[-1] is verdicts[first_done(verdicts) - 1]  # latched
    named = {ref for _, ref in spec.refs()} | {getattr(spec, "mechanism", None)}
    assert {ref for _, ref in reads} <= named, "evaluators read only the refs their spec names"
    again, _ = rollout()
    assert [(v.success, v.failed, v.reason, v.metrics) for v in again] == [
        (v.success, v.failed, v.reason, v.metrics) for v in verdicts
    ]
