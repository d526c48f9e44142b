"""The task registry: every task YAML under the registry folders, validated as a whole.

Search order: the built-in ``registry/`` folder, ``PIPETTE_REGISTRY_PATH`` (``os.pathsep``
separated), folders given with ``--registry-dir``, then third-party task packs declared as
entry points in the group ``pipette.tasks`` (the entry point loads to a folder path, or a
callable returning one or more). Loading is all or nothing: one broken file, an unknown
asset or a duplicate id refuses the whole registry with every problem listed.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Protocol

from pydantic import ValidationError

from pipette_cli.assets.library import AssetLibrary, load_asset_library
from pipette_cli.errors import PipetteError, SpecError, TaskNotFound, suggest
from pipette_cli.resources import data_dir, env_paths
from pipette_cli.specs.robot import ROBOTS_FOLDER
from pipette_cli.specs.task import TaskSpec
from pipette_cli.specs.yaml_io import format_problem, read_yaml, to_plain, validation_problems

log = logging.getLogger(__name__)

REGISTRY_PATH_ENV = "PIPETTE_REGISTRY_PATH"
ENTRY_POINT_GROUP = "pipette.tasks"
YAML_SUFFIXES = (".yaml", ".yml")
SUITES_FOLDER = "suites"
"""The subfolder of a registry folder that holds evaluation suites instead of tasks."""
RESERVED_FOLDERS = (ROBOTS_FOLDER, SUITES_FOLDER)
"""Registry sub-folders that hold other data than tasks (robot facts, evaluation suites)."""


@dataclass(frozen=True)
class RegisteredTask:
    """A validated task and the file it came from."""

    spec: TaskSpec
    path: Path


def load_task_file(path: Path, assets: AssetLibrary | None = None) -> TaskSpec:
    """Read and validate one task YAML file.

    Args:
        path: The YAML file.
        assets: Asset index to check asset ids against (the standard one when omitted).

    Raises:
        SpecError: listing every problem as ``file:line: field: message``.
    """
    doc = read_yaml(path)
    return validate_task_document(doc, str(path), assets)


def validate_task_document(doc: Any, source: str, assets: AssetLibrary | None = None) -> TaskSpec:
    """Validate a parsed YAML document (see :func:`load_task_file`)."""
    raw = to_plain(doc)
    try:
        spec = TaskSpec.model_validate(raw, context={"defer_references": True})
    except ValidationError as exc:
        raise SpecError(validation_problems(exc, TaskSpec, raw, doc, source)) from None
    problems = [format_problem(source, doc, loc, msg) for loc, msg in spec.reference_problems()]
    library = assets if assets is not None else load_asset_library()
    asset_fields: list[tuple[tuple[Any, ...], str]] = [(("scene", "bench"), spec.scene.bench)]
    asset_fields += [(("scene", "objects", i, "asset"), o.asset) for i, o in enumerate(spec.scene.objects)]
    for loc, asset_id in asset_fields:
        if asset_id not in library:
            problems.append(
                format_problem(source, doc, loc, f"unknown asset {asset_id!r}; {suggest(asset_id, library.ids())}")
            )
    if not problems:
        problems = [format_problem(source, doc, loc, msg) for loc, msg in part_problems(spec, library)]
    if problems:
        raise SpecError(problems)
    return spec


PART_KEYS = {"site": ("sites",), "joint": ("joints",), "any": ("sites", "joints", "bodies")}


def part_problems(spec: TaskSpec, library: AssetLibrary) -> list[tuple[tuple[Any, ...], str]]:
    """``(field path, message)`` for every ``object/part`` of the expert program or the success
    criterion that the object's asset does not have (read from the asset's semantics, without
    compiling it)."""
    assets = {o.name: o.asset for o in spec.scene.objects}
    refs = [
        (("expert", i, *loc), ref, kind) for i, step in enumerate(spec.expert or []) for loc, ref, kind in step.parts()
    ]
    refs += _criterion_parts(spec.success.model_dump(mode="json", exclude_none=True), ("success",), set(assets))
    out: list[tuple[tuple[Any, ...], str]] = []
    for loc, ref, kind in refs:
        obj, _, part = ref.partition("/")
        if obj not in assets:
            continue  # reported by reference_problems
        semantics = library.get(assets[obj]).semantics()
        names = [str(n) for key in PART_KEYS[kind] for n in semantics.get(key, [])]
        if part not in names:
            what = "site" if kind == "site" else "joint" if kind == "joint" else "site, joint or body"
            out.append((loc, f"asset {assets[obj]!r} of {obj!r} has no {what} {part!r}; {suggest(part, names)}"))
    return out


def _criterion_parts(node: Any, loc: tuple[Any, ...], objects: set[str]) -> list[tuple[tuple[Any, ...], str, str]]:
    """``(field path, object/part, "any")`` for every value of a criterion that names a part of a
    scene object ("balance/pan_center")."""
    if isinstance(node, dict):
        return [r for key, value in node.items() for r in _criterion_parts(value, (*loc, key), objects)]
    if isinstance(node, list):
        return [r for i, value in enumerate(node) for r in _criterion_parts(value, (*loc, i), objects)]
    obj, _, part = node.partition("/") if isinstance(node, str) else ("", "", "")
    return [(loc, node, "any")] if obj in objects and part else []


def registry_dirs(extra: Iterable[Path] = ()) -> list[Path]:
    """Every folder searched for task YAML, in order (see module docstring)."""
    dirs = [data_dir("registry"), *env_paths(REGISTRY_PATH_ENV), *extra]
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            value = ep.load()
            value = value() if callable(value) else value
        except Exception as exc:  # a third-party pack must not crash the CLI
            raise PipetteError(f"task pack entry point {ep.name!r} ({ep.value}) failed to load: {exc}") from exc
        dirs.extend(Path(v) for v in (value if isinstance(value, list | tuple) else [value]))
    return dirs


def task_files(dirs: Iterable[Path]) -> list[Path]:
    """All YAML files under ``dirs`` (recursively, except each folder's ``suites/``: evaluation
    suites, see :mod:`pipette_cli.evaluation.suites`), de-duplicated, in a stable order."""
    files: list[Path] = []
    seen: set[Path] = set()
    for folder in dirs:
        if not folder.is_dir():
            raise SpecError(f"{folder}: registry folder does not exist")
        for path in sorted(
            p
            for p in folder.rglob("*")
            if p.suffix in YAML_SUFFIXES and p.is_file() and p.relative_to(folder).parts[0] not in RESERVED_FOLDERS
        ):
            resolved = path.resolve()
            if resolved not in seen:
                seen.add(resolved)
                files.append(path)
    return files


def registered_files(extra_dirs: Iterable[Path] = ()) -> dict[str, Path]:
    """Each task id in the registry folders and the file defining it (the first, for an id defined
    twice), read without validating: the registry a task file would join, even where it does not load.
    A file that does not parse is left out."""
    found: dict[str, Path] = {}
    for path in task_files(registry_dirs(extra_dirs)):
        try:
            task_id = read_yaml(path).get("id")
        except SpecError:
            continue
        if isinstance(task_id, str):
            found.setdefault(task_id, path)
    return found


@dataclass(frozen=True)
class Registry:
    """All registered tasks by id."""

    tasks: dict[str, RegisteredTask]

    def ids(self, tag: str | None = None) -> list[str]:
        """Task ids, optionally only those with ``tag`` among their tags, category or robot."""
        return sorted(
            tid
            for tid, t in self.tasks.items()
            if tag is None or tag in t.spec.tags or tag == t.spec.category or tag == t.spec.embodiment.robot
        )

    def using(self, asset_id: str) -> list[str]:
        """Ids of the tasks whose scene places the asset ``asset_id``."""
        return sorted(tid for tid, t in self.tasks.items() if any(o.asset == asset_id for o in t.spec.scene.objects))

    def select(self, which: str) -> list[str]:
        """Task ids a command line names: ``all``, ``benchmark`` (the paper's 12) or a comma list
        of ids or names.

        Raises:
            TaskNotFound: an id of the list is unknown.
        """
        if which in ("all", "benchmark"):
            return self.ids("paper-benchmark" if which == "benchmark" else None)
        return [self.get(t.strip()).id for t in which.split(",") if t.strip()]

    def get(self, task_id: str) -> TaskSpec:
        """The task ``task_id``; ``PickUpTestTube-v1`` and ``PickUpTestTube`` (latest version) work too.

        Raises:
            TaskNotFound: with the closest registered ids.
        """
        return self.entry(task_id).spec

    def entry(self, task_id: str) -> RegisteredTask:
        return self.tasks[resolve_versioned(task_id, self.tasks, "task", TaskNotFound)]


def resolve_versioned(name: str, ids: Iterable[str], what: str, error: type[PipetteError]) -> str:
    """The registered id that ``name`` means: itself, ``Name-vN`` without its namespace, or
    ``Name`` / ``namespace/Name`` without a version (the latest version in each namespace).

    Raises:
        error: no such id (with the closest ids), or ``name`` is ambiguous.
    """
    ids = list(ids)
    if name in ids:
        return name
    candidates = [tid for tid in ids if tid.split("/", 1)[1] == name]
    if not candidates and not re.search(r"-v\d+$", name):
        same = [
            tid
            for tid in ids
            if re.sub(r"-v\d+$", "", tid) == name or re.sub(r"-v\d+$", "", tid.split("/", 1)[1]) == name
        ]
        latest: dict[str, str] = {}
        for tid in sorted(same, key=lambda t: int(t.rsplit("-v", 1)[1])):
            latest[tid.split("/", 1)[0]] = tid
        candidates = list(latest.values())
    if len(candidates) == 1:
        return candidates[0]
    if len(candidates) > 1:
        raise error(f"{what} {name!r} is ambiguous: {', '.join(sorted(candidates))}")
    names = ids + [tid.split("/", 1)[1] for tid in ids]
    full = {tid.split("/", 1)[1]: tid for tid in ids}
    raise error(f"unknown {what} {name!r}; {suggest(name, names, shown_as=full)}")


class Identified(Protocol):
    """A validated spec with a registry id (tasks, suites)."""

    @property
    def id(self) -> str: ...


def load_documents[SpecT: Identified](
    paths: Iterable[Path], validate: Callable[[Any, str], SpecT], what: str
) -> dict[str, tuple[SpecT, Path]]:
    """Read and validate YAML files into specs by id, with the file each came from; all or nothing.

    Args:
        paths: The YAML files.
        validate: ``validate(document, source)``, raising :class:`SpecError`.
        what: The kind of spec, for messages (``"task"``).

    Raises:
        SpecError: every problem in every file, and every duplicate id.
    """
    problems: list[str] = []
    found: dict[str, tuple[SpecT, Path]] = {}
    for path in paths:
        try:
            doc = read_yaml(path)
            spec = validate(doc, str(path))
        except SpecError as exc:
            problems.extend(exc.problems)
            continue
        if spec.id in found:
            problems.append(
                format_problem(
                    str(path), doc, ("id",), f"duplicate {what} id {spec.id!r}, already defined in {found[spec.id][1]}"
                )
            )
            continue
        found[spec.id] = (spec, path)
    if problems:
        raise SpecError(problems)
    log.debug("loaded %d %ss", len(found), what)
    return found


def load_registry(extra_dirs: Iterable[Path] = (), assets: AssetLibrary | None = None) -> Registry:
    """Load and validate every task; all or nothing.

    Raises:
        SpecError: every problem in every file, and every duplicate id.
    """
    library = assets if assets is not None else load_asset_library()
    found = load_documents(
        task_files(registry_dirs(extra_dirs)), lambda doc, source: validate_task_document(doc, source, library), "task"
    )
    return Registry({task_id: RegisteredTask(spec, path) for task_id, (spec, path) in found.items()})
