"""Copies of benchmark tasks with one small change each (an instrument moved, a 60 mm dish for the
90 mm one, a cryovial for the tube, a P200 for the P1000, ...) are solved by the same unchanged
expert programs: the skills read the new geometry from the assets, not from constants."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipette_cli.demos.check import check_expert
from pipette_cli.registry import load_registry

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "variants"
REGISTRY = load_registry([FIXTURES])
VARIANTS = REGISTRY.ids(tag="variant")


def test_there_are_eight_variants() -> None:
    assert len(VARIANTS) == 8


@pytest.mark.parametrize("task_id", VARIANTS, ids=VARIANTS)
def test_the_unchanged_program_solves_the_variant(task_id: str) -> None:
    report = check_expert(REGISTRY.get(task_id), episodes=3, seed=200)
    assert report.successes >= 2, (report.failures, report.expert_failures)
