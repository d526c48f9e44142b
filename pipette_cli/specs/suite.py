"""The evaluation suite spec: one YAML file in ``registry/suites/`` freezes one benchmark.

A suite fixes, per task, the episode seeds and the instruction variants, and for the whole
suite the image size and the render profile, so that two runs of a suite (on two machines, by
two people, a year apart) evaluate the same episodes. Its id is versioned like a task's
(``namespace/Name-vN``): a suite is never edited once results were published with it; a
changed suite is a new version.

Episode ``i`` of a task uses ``seeds[i]`` and ``instructions[i mod len(instructions)]``.

A shifted suite lists ``perturbations`` (lighting, camera pose, object pose, surface colour: the
specs augmentation uses): every episode draws its own values of them from its seed, so a nominal
and a shifted suite over the same seeds evaluate the same starts, one as the task makes them and
one changed.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from pipette_cli.specs.base import Spec
from pipette_cli.specs.perturbations import PerturbationField
from pipette_cli.specs.task import TASK_ID_PATTERN

SUITE_ID_PATTERN = TASK_ID_PATTERN
DEFAULT_EPISODES = 75
"""Episodes per task when a suite does not say: the count the field's benchmarks use."""
DEFAULT_FIRST_SEED = 100_000
"""First evaluation seed by default: far from demonstration seeds (0, 1, ...)."""


class SeedRangeSpec(Spec):
    """``count`` consecutive seeds from ``first``."""

    first: int = Field(DEFAULT_FIRST_SEED, ge=0)
    count: int = Field(DEFAULT_EPISODES, ge=1, le=100_000)

    def seeds(self) -> list[int]:
        return list(range(self.first, self.first + self.count))


SeedList = Annotated[list[Annotated[int, Field(ge=0)]], Field(min_length=1, max_length=100_000)]


class SuiteTaskSpec(Spec):
    """One task of a suite: which task (full versioned id), its seeds and its instructions."""

    task: str = Field(
        pattern=TASK_ID_PATTERN, description="full task id with its version, e.g. pipette/PickUpTestTube-v1"
    )
    seeds: SeedRangeSpec | SeedList | None = Field(
        None, description="a range {first, count} or a list; default: the suite's"
    )
    instructions: list[Annotated[str, Field(min_length=1, max_length=2000)]] = Field(
        min_length=1, description="instruction variants, used in turn: episode i gets instructions[i mod n]"
    )

    @model_validator(mode="after")
    def _unique(self) -> SuiteTaskSpec:
        if isinstance(self.seeds, list) and len(set(self.seeds)) != len(self.seeds):
            doubled = sorted({s for s in self.seeds if self.seeds.count(s) > 1})
            raise ValueError(f"seeds repeat: {doubled[:5]}; every episode needs its own seed")
        if len(set(self.instructions)) != len(self.instructions):
            raise ValueError("instructions repeat; list each variant once")
        return self


class SuiteSpec(Spec):
    """A frozen evaluation suite."""

    id: str = Field(pattern=SUITE_ID_PATTERN, description="namespace/Name-vN, e.g. pipette/PaperBenchmark-v1")
    name: str = Field(min_length=1)
    description: str = ""
    image_size: int | None = Field(None, ge=16, le=4096, description="square image side; default: the tasks' cameras")
    render_profile: Literal["fast", "full"] = "fast"
    seeds: SeedRangeSpec = SeedRangeSpec()
    tasks: list[SuiteTaskSpec] = Field(min_length=1)
    perturbations: list[PerturbationField] = Field(
        default_factory=list, description="conditions drawn per episode from its seed (a shifted suite)"
    )

    @model_validator(mode="after")
    def _distinct_tasks(self) -> SuiteSpec:
        ids = [t.task for t in self.tasks]
        doubled = sorted({t for t in ids if ids.count(t) > 1})
        if doubled:
            raise ValueError(f"task {doubled[0]} is listed twice")
        kinds = [p.type for p in self.perturbations]
        if len(kinds) != len(set(kinds)):
            raise ValueError(f"perturbations list a type twice: {kinds}")
        on_demo = [p.type for p in self.perturbations if p.needs_demo]
        if on_demo:
            raise ValueError(
                f"{', '.join(on_demo)} are drawn around a demonstration (they rewrite its actions); "
                "an evaluation has none (use lighting, camera_pose, object_pose, surface_color, distractors)"
            )
        return self

    @property
    def version(self) -> int:
        """The ``N`` of ``...-vN``."""
        return int(self.id.rsplit("-v", 1)[1])

    def task_seeds(self, entry: SuiteTaskSpec) -> list[int]:
        """The seeds of one task: its own list or range, else the suite's range."""
        if isinstance(entry.seeds, list):
            return list(entry.seeds)
        return (entry.seeds or self.seeds).seeds()
