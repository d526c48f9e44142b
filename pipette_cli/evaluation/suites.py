"""Evaluation suites: the YAML files in each registry folder's ``suites/``, validated as a whole.

A suite (:class:`~pipette_cli.specs.suite.SuiteSpec`) freezes what an evaluation runs: per task
the seeds and instruction variants, and the image size and render profile. Suites are found in
the ``suites/`` subfolder of every registry folder (the built-in ``registry/``,
``PIPETTE_REGISTRY_PATH``, ``--registry-dir``, task packs), so a lab ships its suites next to
its tasks. Every task a suite names must be registered, at exactly the version it names.

:func:`episode_plan` expands a suite into the episodes to run; :func:`adhoc_plan` does the same
for ``pipette eval TASK --episodes N --seed S`` without a suite.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from pipette_cli.errors import SpecError, SuiteNotFound, suggest
from pipette_cli.registry import (
    SUITES_FOLDER,
    YAML_SUFFIXES,
    Registry,
    load_documents,
    registry_dirs,
    resolve_versioned,
)
from pipette_cli.specs.perturbations import PerturbationSpec
from pipette_cli.specs.suite import SuiteSpec
from pipette_cli.specs.task import TaskSpec
from pipette_cli.specs.yaml_io import format_problem, read_yaml, to_plain, validation_problems

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class EpisodePlan:
    """One episode to evaluate: task, index within the task, seed, instruction and the shifted
    suite's perturbations (drawn from the seed when the episode runs)."""

    task: str
    index: int
    seed: int
    instruction: str
    conditions: tuple[PerturbationSpec, ...] = ()


@dataclass(frozen=True)
class RegisteredSuite:
    """A validated suite and the file it came from."""

    spec: SuiteSpec
    path: Path

    @property
    def sha256(self) -> str:
        """SHA-256 of the suite's canonical JSON: two runs with the same hash ran the same episodes."""
        return suite_sha256(self.spec)

    def record(self) -> dict[str, Any]:
        """What results store about the suite: id, version and hash."""
        return {"id": self.spec.id, "version": self.spec.version, "sha256": self.sha256}


def suite_sha256(spec: SuiteSpec) -> str:
    # a suite without perturbations hashes as before they existed: published hashes stay valid
    dump = spec.model_dump(mode="json", exclude=set() if spec.perturbations else {"perturbations"})
    canonical = json.dumps(dump, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()


def suite_files(dirs: Iterable[Path]) -> list[Path]:
    """Every YAML file under ``<dir>/suites/`` of each registry folder, de-duplicated, in order."""
    files: list[Path] = []
    seen: set[Path] = set()
    for folder in dirs:
        suites = Path(folder) / SUITES_FOLDER
        if not suites.is_dir():
            continue
        for path in sorted(p for p in suites.rglob("*") if p.suffix in YAML_SUFFIXES and p.is_file()):
            if path.resolve() not in seen:
                seen.add(path.resolve())
                files.append(path)
    return files


def validate_suite_document(doc: Any, source: str, registry: Registry) -> SuiteSpec:
    """Validate a parsed suite YAML document against the schema and the task registry.

    Raises:
        SpecError: every problem as ``file:line: field: message``.
    """
    raw = to_plain(doc)
    try:
        spec = SuiteSpec.model_validate(raw)
    except ValidationError as exc:
        raise SpecError(validation_problems(exc, SuiteSpec, raw, doc, source)) from None
    problems = []
    for i, entry in enumerate(spec.tasks):
        if entry.task not in registry.tasks:
            problems.append(
                format_problem(
                    source,
                    doc,
                    ("tasks", i, "task"),
                    f"unknown task {entry.task!r}; {suggest(entry.task, registry.tasks)}",
                )
            )
    if problems:
        raise SpecError(problems)
    return spec


def load_suite_file(path: Path, registry: Registry) -> SuiteSpec:
    """Read and validate one suite file (see :func:`validate_suite_document`)."""
    return validate_suite_document(read_yaml(path), str(path), registry)


@dataclass(frozen=True)
class Suites:
    """All registered suites by id."""

    suites: dict[str, RegisteredSuite]

    def ids(self) -> list[str]:
        return sorted(self.suites)

    def get(self, suite_id: str) -> RegisteredSuite:
        """The suite ``suite_id``; without a version, the latest one.

        Raises:
            SuiteNotFound: with the closest registered ids.
        """
        return self.suites[resolve_versioned(suite_id, self.suites, "suite", SuiteNotFound)]


def load_suites(registry: Registry, extra_dirs: Iterable[Path] = ()) -> Suites:
    """Load and validate every suite of the registry folders; all or nothing.

    Raises:
        SpecError: every problem in every file, and every duplicate id.
    """
    found = load_documents(
        suite_files(registry_dirs(extra_dirs)),
        lambda doc, source: validate_suite_document(doc, source, registry),
        "suite",
    )
    return Suites({suite_id: RegisteredSuite(spec, path) for suite_id, (spec, path) in found.items()})


def episode_plan(suite: SuiteSpec, tasks: Iterable[str] | None = None) -> dict[str, list[EpisodePlan]]:
    """The episodes of ``suite`` by task id, in suite order; ``tasks`` picks some of its tasks.

    Raises:
        SuiteNotFound: a task in ``tasks`` is not part of the suite.
    """
    entries = {entry.task: entry for entry in suite.tasks}
    wanted = list(entries) if tasks is None else list(tasks)
    plan: dict[str, list[EpisodePlan]] = {}
    for task_id in wanted:
        if task_id not in entries:
            raise SuiteNotFound(f"task {task_id} is not in suite {suite.id}; it has {', '.join(entries)}")
        entry = entries[task_id]
        variants = entry.instructions
        plan[task_id] = [
            EpisodePlan(task_id, i, seed, variants[i % len(variants)], tuple(suite.perturbations))
            for i, seed in enumerate(suite.task_seeds(entry))
        ]
    return plan


def adhoc_plan(task: TaskSpec, episodes: int, seed: int) -> list[EpisodePlan]:
    """``episodes`` episodes of ``task`` with seeds ``seed + i`` and the task's own instruction."""
    return [EpisodePlan(task.id, i, seed + i, task.instruction) for i in range(episodes)]
