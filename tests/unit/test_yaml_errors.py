"""Broken task files: every kind of error names file:line, the field, and what is expected."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipette_cli.errors import SpecError
from pipette_cli.registry import load_task_file
from pipette_cli.specs.yaml_io import dump_yaml, parse_yaml

BROKEN = Path(__file__).parents[1] / "fixtures" / "tasks" / "broken"

# file -> (line, text the message must contain)
CASES = {
    "syntax.yaml": (13, "YAML syntax error"),
    "unknown_key.yaml": (24, "success.hold_seconds: unknown key 'hold_seconds'; did you mean 'hold_s'?"),
    "wrong_type.yaml": (24, "success.timeout_s: Input should be a valid number"),
    "unknown_asset.yaml": (
        13,
        "scene.objects.0.asset: unknown asset 'test_tube_16x15'; did you mean 'test_tube_16x150'",
    ),
    "unknown_evaluator.yaml": (
        21,
        "success.type: unknown evaluator type 'lift_and_hould'; did you mean 'lift_and_hold'",
    ),
    "unknown_object.yaml": (22, "success.object: 'tubes' names no scene object; did you mean 'tube'?"),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_error_names_file_line_and_field(name: str) -> None:
    line, text = CASES[name]
    path = BROKEN / name
    with pytest.raises(SpecError) as info:
        load_task_file(path)
    assert len(info.value.problems) == 1
    problem = info.value.problems[0]
    assert problem.startswith(f"{path}:{line}: "), problem
    assert text in problem


def test_all_problems_in_a_file_are_reported_at_once(tmp_path: Path) -> None:
    text = (BROKEN.parent / "valid_pick.yaml").read_text()
    text = text.replace("timeout_s: 8", "timeout_s: eight").replace(
        "category: consumable_handling", "category: handling"
    )
    path = tmp_path / "two.yaml"
    path.write_text(text)
    with pytest.raises(SpecError) as info:
        load_task_file(path)
    assert [p.split(": ")[1] for p in info.value.problems] == ["category", "success.timeout_s"]


@pytest.mark.parametrize("text", ["- just\n- a list\n", "42\n", ""])
def test_top_level_must_be_a_mapping(text: str) -> None:
    with pytest.raises(SpecError, match="expected a mapping"):
        parse_yaml(text, "x.yaml")


def test_round_trip_keeps_comments() -> None:
    text = "# head\nid: a/B-v1  # trailing\nlist: [1, 2]\nnested:\n  - {a: 1}\n  - b: 2\n    c: 3\n"
    assert dump_yaml(parse_yaml(text)) == text
