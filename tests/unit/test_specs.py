"""Task spec models: strict validation, pluggable evaluator types, cross references."""

from __future__ import annotations

import copy
from typing import Literal

import pytest
from pydantic import ValidationError

from pipette_cli.errors import SpecError
from pipette_cli.specs import TaskSpec, evaluator_types, register_evaluator
from pipette_cli.specs.evaluators import EvaluatorSpec
from pipette_cli.specs.task import TimingSpec

BASE: dict = {
    "id": "testlab/PickUpThing-v1",
    "name": "Pick up the thing",
    "category": "consumable_handling",
    "instruction": "Pick up the thing.",
    "embodiment": {"robot": "franka_panda", "initial_joints": [0, -0.3, 0, -2.2, 0, 1.9, 0.785]},
    "scene": {"objects": [{"name": "tube", "asset": "test_tube_16x150", "pose": {"pos": [0.5, 0, 0.55]}}]},
    "cameras": {
        "top": {"pos": [0.5, 0, 1.5], "look_at": [0.5, 0, 0.55]},
        "main": {"pos": [1.3, -0.5, 1.1], "look_at": [0.5, 0, 0.6]},
        "wrist": {"mount": "end_effector", "pos": [0.06, 0, 0], "euler_deg": [180, 0, -90]},
    },
    "targets": ["tube"],
    "success": {"type": "lift_and_hold", "object": "tube", "min_height_gain": 0.02, "timeout_s": 7},
}


def spec_with(**changes) -> dict:
    data = copy.deepcopy(BASE)
    for dotted, value in changes.items():
        node = data
        *parents, last = dotted.split("__")
        for key in parents:
            node = node[int(key)] if key.isdigit() else node[key]
        node[last] = value
    return data


def error_locs(data: dict) -> list[tuple]:
    with pytest.raises(ValidationError) as info:
        TaskSpec.model_validate(data)
    return [tuple(e["loc"]) for e in info.value.errors()]


def test_minimal_spec_gets_paper_defaults() -> None:
    spec = TaskSpec.model_validate(BASE)
    assert (spec.cameras.width, spec.cameras.height) == (400, 400)
    assert (spec.timing.control_hz, spec.timing.vision_hz) == (30, 10)
    assert spec.timing.substeps == 20 and spec.timing.vision_every == 3
    assert spec.timing.physics_dt == pytest.approx(1 / 600)
    assert spec.success.type == "lift_and_hold" and spec.success.hold_s == 0.5


def test_specs_are_frozen() -> None:
    spec = TaskSpec.model_validate(BASE)
    with pytest.raises(ValidationError):
        spec.name = "changed"  # type: ignore[misc]


def test_unknown_key_is_rejected_with_its_path() -> None:
    assert error_locs(spec_with(success__hold_seconds=1)) == [("success", "hold_seconds")]
    assert error_locs(spec_with(scene__objects__0__colour="red")) == [("scene", "objects", 0, "colour")]


def test_unknown_evaluator_type_suggests_the_closest() -> None:
    with pytest.raises(ValidationError, match="did you mean 'lift_and_hold'"):
        TaskSpec.model_validate(spec_with(success__type="lift_and_hould"))


def test_missing_evaluator_type_lists_the_known_ones() -> None:
    data = spec_with()
    del data["success"]["type"]
    with pytest.raises(ValidationError, match="joint_threshold"):
        TaskSpec.model_validate(data)


def test_arm_dof_must_match_the_robot() -> None:
    with pytest.raises(ValidationError, match="agilex_piper has 6 arm joints"):
        TaskSpec.model_validate(spec_with(embodiment__robot="agilex_piper"))


def test_unknown_robot_is_rejected() -> None:
    assert error_locs(spec_with(embodiment__robot="kuka_iiwa")) == [("embodiment", "robot")]


def test_timing_must_divide_evenly() -> None:
    with pytest.raises(ValidationError, match="multiple of control_hz"):
        TimingSpec(physics_hz=500, control_hz=30, vision_hz=10)
    with pytest.raises(ValidationError, match="multiple of vision_hz"):
        TimingSpec(physics_hz=600, control_hz=30, vision_hz=7)


def test_bounds_need_an_end_and_an_order() -> None:
    with pytest.raises(ValidationError, match="below 'max'"):
        TaskSpec.model_validate(
            spec_with(success={"type": "joint_threshold", "joint": "tube/hinge", "bound": {"min": 5, "max": 1}})
        )
    with pytest.raises(ValidationError, match="at least one of 'min' and 'max'"):
        TaskSpec.model_validate(spec_with(success={"type": "joint_threshold", "joint": "tube/hinge", "bound": {}}))


def test_camera_needs_exactly_one_orientation() -> None:
    with pytest.raises(ValidationError, match="exactly one of 'look_at' and 'euler_deg'"):
        TaskSpec.model_validate(spec_with(cameras__top={"pos": [0, 0, 1]}))


def test_references_to_missing_objects_are_errors() -> None:
    with pytest.raises(ValidationError, match="'tubes' names no scene object; did you mean 'tube'"):
        TaskSpec.model_validate(spec_with(success__object="tubes"))
    with pytest.raises(ValidationError, match="targets.0"):
        TaskSpec.model_validate(spec_with(targets=["rack"]))


def test_composite_children_are_checked_too() -> None:
    child_ok = {"type": "lift_and_hold", "object": "tube", "min_height_gain": 0.02}
    child_bad = {"type": "region_hold", "object": "dish", "z": {"min": 0.6}}
    spec = TaskSpec.model_validate(spec_with(success={"type": "sequence", "of": [child_ok, child_ok]}))
    assert [c.type for c in spec.success.of] == ["lift_and_hold", "lift_and_hold"]
    with pytest.raises(ValidationError, match=r"success\.of\.1\.object"):
        TaskSpec.model_validate(spec_with(success={"type": "all", "of": [child_ok, child_bad]}))


def test_mechanism_evaluator_needs_a_defined_mechanism() -> None:
    success = {"type": "mechanism_triggered", "mechanism": "lid_release", "target": {"max": -39}}
    with pytest.raises(ValidationError, match="mechanism 'lid_release' is not defined"):
        TaskSpec.model_validate(spec_with(success=success))


def test_notes_must_name_real_fields() -> None:
    ok = spec_with(notes=[{"field": "success.min_height_gain", "note": "paper A.8"}])
    assert TaskSpec.model_validate(ok).notes[0].field == "success.min_height_gain"
    with pytest.raises(ValidationError, match="'success.min_height' is not a field"):
        TaskSpec.model_validate(spec_with(notes=[{"field": "success.min_height", "note": "x"}]))


def test_dump_and_reload_is_identity() -> None:
    spec = TaskSpec.model_validate(BASE)
    assert TaskSpec.model_validate(spec.model_dump(mode="json")) == spec


def test_third_party_evaluator_registers_without_editing_a_list() -> None:
    @register_evaluator
    class PouredSpec(EvaluatorSpec):
        type: Literal["test_poured_volume"] = "test_poured_volume"
        min_ml: float

    assert "test_poured_volume" in evaluator_types()
    spec = TaskSpec.model_validate(spec_with(success={"type": "test_poured_volume", "min_ml": 5}))
    assert isinstance(spec.success, PouredSpec) and spec.success.min_ml == 5
    assert spec.model_dump()["success"] == {
        "type": "test_poured_volume",
        "timeout_s": None,
        "instruction": None,
        "min_ml": 5.0,
    }

    class Impostor(EvaluatorSpec):
        type: Literal["test_poured_volume"] = "test_poured_volume"

    with pytest.raises(SpecError, match="defined twice"):
        register_evaluator(Impostor)
