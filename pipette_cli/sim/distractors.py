"""Distractor objects standing on the bench: what an augmented episode recorded
(``augment_distractors``) and the task with them in its scene. Where they go is drawn by
:mod:`pipette_cli.augment.clutter`; replaying or verifying an episode rebuilds its scene here."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

from pipette_cli.specs.base import BENCH_TOP_Z, PoseSpec
from pipette_cli.specs.task import ObjectSpec, TaskSpec

PREFIX = "distractor"
ATTR = "augment_distractors"
"""The episode attribute that lists them (JSON)."""


@dataclass(frozen=True)
class Distractor:
    asset: str
    x: float
    y: float
    yaw_deg: float

    def as_dict(self) -> dict[str, float | str]:
        return asdict(self)


def with_distractors(task: TaskSpec, distractors: list[Distractor]) -> TaskSpec:
    """``task`` with ``distractors`` standing on the bench (fixed poses, no randomisation);
    ``task`` itself without any."""
    if not distractors:
        return task
    extra = [
        ObjectSpec(
            name=f"{PREFIX}_{i}",
            asset=d.asset,
            pose=PoseSpec(pos=(d.x, d.y, BENCH_TOP_Z), euler_deg=(0.0, 0.0, d.yaw_deg)),
        )
        for i, d in enumerate(distractors)
    ]
    scene = task.scene.model_copy(update={"objects": [*task.scene.objects, *extra]})
    return task.model_copy(update={"scene": scene})


def distractors_from_attrs(attrs: dict[str, object]) -> list[Distractor]:
    """The distractors an augmented episode was recorded with (``augment_distractors``)."""
    raw = attrs.get(ATTR)
    return [Distractor(**item) for item in json.loads(str(raw))] if raw else []
