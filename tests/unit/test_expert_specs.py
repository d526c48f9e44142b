"""The ``expert:`` section: a typed skill program, checked against the scene and the assets with
file:line errors and did-you-mean, and derived from the success criterion when it is missing."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import pytest

from pipette_cli.errors import SpecError
from pipette_cli.registry import validate_task_document
from pipette_cli.resources import data_dir
from pipette_cli.skills.derive import derive_program
from pipette_cli.specs.expert import CloseHingeSpec, OpenHingeSpec, PickSpec, PlaceOnSpec, PressSpec, skill_names
from pipette_cli.specs.yaml_io import parse_yaml

BALANCE = data_dir("registry") / "place_tube_on_balance.yaml"


def with_program(program: str) -> tuple[str, int]:
    """The balance task's YAML with its ``expert:`` section replaced, and the line the section starts on."""
    text = BALANCE.read_text(encoding="utf-8")
    head, _, rest = text.partition("expert:\n")
    tail = rest[rest.index("notes:") :] if "notes:" in rest else ""
    return head + "expert:\n" + program + tail, head.count("\n") + 1


def problems(program: str) -> tuple[list[str], int]:
    text, line = with_program(program)
    with pytest.raises(SpecError) as err:
        validate_task_document(parse_yaml(text, "task.yaml"), "task.yaml")
    return err.value.problems, line


def test_the_shipped_program_validates() -> None:
    text, _ = with_program(
        "  - {skill: pick, object: tube}\n  - {skill: place_on, object: tube, target: balance/pan_center}\n"
    )
    spec = validate_task_document(parse_yaml(text, "task.yaml"), "task.yaml")
    assert [s.skill for s in spec.expert or []] == ["pick", "place_on"]


def test_an_unknown_skill_names_the_line_and_a_close_one() -> None:
    found, line = problems("  - {skill: pik, object: tube}\n")
    assert found == [f"task.yaml:{line + 1}: expert.0.skill: unknown skill 'pik'; did you mean 'pick'?"]


def test_an_unknown_object_names_the_line_and_a_close_one() -> None:
    found, line = problems(
        "  - {skill: pick, object: tube}\n  - {skill: place_on, object: tbe, target: balance/pan_center}\n"
    )
    assert found == [f"task.yaml:{line + 2}: expert.1.object: 'tbe' names no scene object; did you mean 'tube'?"]


def test_an_unknown_site_names_the_asset_and_its_sites() -> None:
    found, line = problems(
        "  - {skill: pick, object: tube}\n  - {skill: place_on, object: tube, target: balance/pan_centre}\n"
    )
    assert found == [
        f"task.yaml:{line + 2}: expert.1.target: asset 'electronic_balance' of 'balance' has no site "
        "'pan_centre'; did you mean 'pan_center'?"
    ]


def test_an_unknown_joint_names_the_asset() -> None:
    found, _ = problems("  - {skill: close_hinge, joint: balance/lid_hinge}\n")
    assert len(found) == 1 and "asset 'electronic_balance' of 'balance' has no joint 'lid_hinge'" in found[0]


def test_an_unknown_key_of_a_step_is_refused_with_its_fields() -> None:
    found, line = problems("  - {skill: pick, object: tube, lfit: 0.1}\n")
    assert found == [f"task.yaml:{line + 1}: expert.0.lfit: unknown key 'lfit'; did you mean 'lift'?"]


def test_every_documented_skill_is_registered() -> None:
    assert set(skill_names()) >= {
        "pick",
        "place_on",
        "insert_into",
        "remove_from",
        "open_hinge",
        "close_hinge",
        "slide",
        "press",
        "position_over",
        "tilt",
        "retreat",
        "move",
        "wait",
    }


def test_every_skill_spec_has_a_runtime_and_every_runtime_a_spec() -> None:
    from pipette_cli.skills.library import skill_runtime, unmatched_skills
    from pipette_cli.skills.runtime import SKILL_RUNTIMES

    assert unmatched_skills() == []
    assert SKILL_RUNTIMES.names() == skill_names()
    wait = SKILL_RUNTIMES.remove("wait")  # a spec left without its runtime is named
    try:
        assert wait is not None
        (found,) = unmatched_skills()
        assert found.startswith("skill 'wait' has a spec (") and "but no runtime" in found
    finally:
        SKILL_RUNTIMES.add("wait", wait)
    assert skill_runtime(PickSpec).__name__ == "pick"


def test_a_runtime_registers_only_against_a_registered_spec() -> None:
    from pipette_cli.skills.runtime import skill
    from pipette_cli.specs.expert import StepSpec

    class StirSpec(StepSpec):  # never passed to register_skill
        skill: Literal["stir"] = "stir"

    with pytest.raises(SpecError, match="StirSpec is not a registered skill type"):
        skill(StirSpec)


def test_programs_derived_from_criteria() -> None:
    from pipette_cli.registry import load_registry

    registry = load_registry()
    no_program = {tid: registry.get(tid).model_copy(update={"expert": None}) for tid in registry.ids()}
    place = derive_program(no_program["pipette/PlaceTubeOnBalance-v1"])
    assert [type(s) for s in place] == [PickSpec, PlaceOnSpec] and place[1].target == "balance/pan_center"
    close = derive_program(no_program["pipette/CloseCentrifugeLid-v1"])
    assert [type(s) for s in close] == [CloseHingeSpec]
    press = derive_program(no_program["pipette/OpenCentrifugeLid-v1"])
    assert [type(s) for s in press] == [PressSpec] and press[0].button == "centrifuge/button"
    # a bound away from the closed angle opens
    cycler = no_program["generated/CloseThermalCyclerLid-v1"]
    opening = cycler.model_copy(
        update={
            "success": cycler.success.model_copy(
                update={"bound": cycler.success.bound.model_copy(update={"min": 80.0, "max": None})}
            ),
            "scene": cycler.scene.model_copy(update={"joint_states": []}),
        }
    )
    assert [type(s) for s in derive_program(opening)] == [OpenHingeSpec]


def test_a_sequence_criterion_chains_its_stages_programs() -> None:
    from pipette_cli.registry import load_registry
    from pipette_cli.specs.evaluators import SequenceSpec

    task = load_registry().get("PlaceTubeOnBalance")
    seq = task.model_copy(update={"expert": None, "success": SequenceSpec(of=[task.success, task.success])})
    assert [s.skill for s in derive_program(seq)] == ["pick", "place_on", "pick", "place_on"]


def test_the_registry_yaml_files_stay_readable(tmp_path: Path) -> None:
    """Every shipped task's program round-trips through its YAML (no alias surprises: ``from:``)."""
    text = (data_dir("registry") / "remove_tube_from_balance.yaml").read_text(encoding="utf-8")
    spec = validate_task_document(parse_yaml(text, "t.yaml"), "t.yaml")
    step = (spec.expert or [])[0]
    assert step.source == "balance" and step.model_dump(by_alias=True)["from"] == "balance"
