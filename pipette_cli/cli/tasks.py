"""``pipette tasks``: list, show, validate and create task specs."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Any

import typer

from pipette_cli.assets.library import load_asset_library
from pipette_cli.cli.common import STATE, err_console, out_console, print_json, show_progress, wrote_task_line
from pipette_cli.cli.listing import Column, Listing
from pipette_cli.demos.experts.base import expert_program
from pipette_cli.demos.feasibility import scene_problems
from pipette_cli.errors import PipetteError, SpecError, plural, suggest
from pipette_cli.evaluation.suites import load_suites
from pipette_cli.registry import (
    YAML_SUFFIXES,
    Registry,
    load_registry,
    registered_files,
    registry_dirs,
    task_files,
    validate_task_document,
)
from pipette_cli.specs.robot import DEFAULT_ROBOT, robot_spec
from pipette_cli.specs.task import TASK_ID_PATTERN, TaskSpec, stage_specs
from pipette_cli.specs.yaml_io import dump_yaml, format_problem, parse_yaml, read_yaml
from pipette_cli.templating import render_task_template, task_template_names

app = typer.Typer(
    help="Browse, check and create task specs.\n\nExample: pipette tasks list --tag hatch_control", no_args_is_help=True
)


def _registry() -> Registry:
    return load_registry(STATE.registry_dirs)


def _summary(spec: TaskSpec) -> dict[str, object]:
    return {
        "id": spec.id,
        "name": spec.name,
        "category": spec.category,
        "embodiment": spec.embodiment.robot,
        "evaluator": spec.success.type,
        "tags": list(spec.tags),
        "instruction": spec.instruction,
        "stages": _stages(spec),
    }


def _stages(spec: TaskSpec) -> list[dict[str, object]]:
    """A protocol's stages in order: each one's instruction and criterion (``[]`` for one-step tasks)."""
    return [
        {"stage": i + 1, "instruction": stage.instruction, "criterion": stage.type}
        for i, stage in enumerate(stage_specs(spec))
    ]


def _evaluator(spec: TaskSpec) -> str:
    count = len(stage_specs(spec))
    return f"{spec.success.type} ({plural(count, 'stage')})" if count else spec.success.type


@app.command("list")
def list_tasks(
    tag: Annotated[str | None, typer.Option("--tag", "-t", help="Only tasks with this tag, category or robot.")] = None,
    asset: Annotated[str | None, typer.Option("--asset", help="Asset id: only tasks whose scene places it.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """List registered tasks.

    Example: pipette tasks list --tag paper-benchmark --json; pipette tasks list --asset thermal_cycler
    """
    registry = _registry()
    ids = registry.ids(tag)
    if asset is not None:
        asset = load_asset_library().get(asset).asset_id  # an unknown id: the library's error with the closest ids
        using = set(registry.using(asset))
        ids = [tid for tid in ids if tid in using]
    specs = [registry.get(tid) for tid in ids]
    if as_json:
        print_json([_summary(s) for s in specs])
        return
    columns = [Column("id"), Column("robot"), Column("evaluator"), Column("instruction", wrap=True)]
    rows = [[s.id, s.embodiment.robot, _evaluator(s), s.instruction] for s in specs]
    out_console.print(Listing(plural(len(specs), "task"), columns, rows))


@app.command("suites")
def list_suites(
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """List the frozen evaluation suites (registry/suites/) that `pipette eval --suite` runs.

    Example: pipette tasks suites
    """
    suites = load_suites(_registry(), STATE.registry_dirs)
    rows: list[dict[str, Any]] = []
    for suite_id in suites.ids():
        entry = suites.get(suite_id)
        spec = entry.spec
        rows.append(
            {
                "id": spec.id,
                "name": spec.name,
                "tasks": [t.task for t in spec.tasks],
                "episodes": sum(len(spec.task_seeds(t)) for t in spec.tasks),
                "image_size": spec.image_size,
                "render_profile": spec.render_profile,
                "perturbations": [p.model_dump(mode="json") for p in spec.perturbations],
                "sha256": entry.sha256,
                "path": str(entry.path),
            }
        )
    if as_json:
        print_json(rows)
        return
    columns = [
        Column("id"),
        Column("tasks", justify="right"),
        Column("episodes", justify="right"),
        Column("image"),
        Column("name", wrap=True),
        Column("varied per episode", wrap=True),
    ]
    cells = [
        [
            r["id"],
            str(len(r["tasks"])),
            str(r["episodes"]),
            f"{r['image_size'] or 'task'} px",
            r["name"],
            ", ".join(p["type"] for p in r["perturbations"]),
        ]
        for r in rows
    ]
    out_console.print(Listing(plural(len(rows), "evaluation suite"), columns, cells))


@app.command("show")
def show_task(
    task_id: Annotated[str, typer.Argument(help="Task id, e.g. pipette/PickUpTestTube-v1 or PickUpTestTube.")],
    as_json: Annotated[bool, typer.Option("--json", help="The full spec as JSON.")] = False,
) -> None:
    """Show one task: the YAML file as written (comments included), or the validated spec.

    Example: pipette tasks show PickUpTestTube
    """
    entry = _registry().entry(task_id)
    program, source = _program(entry.spec)
    if as_json:
        print_json(
            {
                "path": str(entry.path),
                **entry.spec.model_dump(mode="json", by_alias=True),
                "expert_program": {"source": source, "steps": program},
                "stages": _stages(entry.spec),
            }
        )
        return
    out_console.print(f"# {entry.path}", style="dim")
    out_console.print(entry.path.read_text(encoding="utf-8"), markup=False, highlight=False, end="")
    stages = _stages(entry.spec)
    if stages:
        out_console.print(
            f"# {plural(len(stages), 'stage')} (progress = stages completed / {len(stages)}):", style="dim"
        )
        for row in stages:
            out_console.print(
                f"#   {row['stage']}. {row['instruction'] or '(no instruction)'}  [{row['criterion']}]",
                style="dim",
                markup=False,
                highlight=False,
            )
    if source != "task":
        out_console.print(f"# expert program in use ({source}):", style="dim")
        out_console.print(
            dump_yaml({"expert": program}) if program else "# (none)\n", markup=False, highlight=False, end=""
        )


def _program(spec) -> tuple[list[dict], str]:
    """The expert program a task runs, as plain data, and where it comes from (``task``, ``derived``,
    or why there is none)."""
    try:
        steps, source = expert_program(spec)
    except PipetteError as exc:
        return [], f"none: {exc}"
    data = [{"skill": s.skill, **s.model_dump(mode="json", by_alias=True, exclude_defaults=True)} for s in steps]
    return data, "task" if source == "task" else "derived from the success criterion"


@app.command("validate")
def validate_tasks(
    paths: Annotated[
        list[Path] | None, typer.Argument(help="YAML files or folders (default: the whole registry).")
    ] = None,
    physics: Annotated[
        bool,
        typer.Option(
            "--physics/--no-physics",
            help="Also build each scene: no interpenetration at reset, every object and work point in the robot's reach.",
        ),
    ] = True,
) -> None:
    """Check task files; every problem is printed as file:line: field: message.

    Runs what loading the registry runs (fields, assets, parts, duplicate ids: among the files given
    and against the registry they would join, naming both files), then builds each scene (about
    0.2 s a task): nothing interpenetrates at reset, every object and every point the expert works
    at is within the robot's reach from its base. Exits 1 if any file is invalid. Without PATHs,
    validates the whole registry and the evaluation suites in each folder's suites/.

    Example: pipette tasks validate registry/pick_up_test_tube.yaml
    """
    if not paths:
        _validate_registry(physics)
        return
    files: list[Path] = []
    for path in paths:
        if path.is_dir():
            files.extend(task_files([path]))
        elif path.suffix in YAML_SUFFIXES or path.exists():
            files.append(path)
        else:
            raise PipetteError(f"{path}: no such file or folder")
    registered = registered_files(STATE.registry_dirs)  # also imports task packs (their evaluator types)
    problems: list[str] = []
    seen: dict[str, Path] = {}
    valid: list[tuple[Path, Any, TaskSpec]] = []
    for path in dict.fromkeys(files):
        try:
            doc = read_yaml(path)
            spec = validate_task_document(doc, str(path))
        except SpecError as exc:
            problems.extend(exc.problems)
            continue
        other = seen.get(spec.id) or registered.get(spec.id)
        if other is not None and other.resolve() != path.resolve():
            problems.append(
                format_problem(str(path), doc, ("id",), f"duplicate task id {spec.id!r}, already defined in {other}")
            )
            continue
        seen[spec.id] = path
        valid.append((path, doc, spec))
    failed = _physical_problems(valid) if physics else []
    problems += failed
    for path, _, spec in valid:
        if not any(line.startswith(f"{path}:") for line in failed):
            err_console.print(f"ok  {path}  ({spec.id})", markup=False, soft_wrap=True)
    if problems:
        raise SpecError(problems)


def _validate_registry(physics: bool) -> None:
    registry = _registry()
    suites = load_suites(registry, STATE.registry_dirs)
    if physics:
        entries = [registry.tasks[tid] for tid in registry.ids()]
        problems = _physical_problems([(e.path, read_yaml(e.path), e.spec) for e in entries])
        if problems:
            raise SpecError(problems)
    err_console.print(
        f"{plural(len(registry.tasks), 'task')} and {plural(len(suites.suites), 'evaluation suite')} valid in "
        f"{plural(len(registry_dirs(STATE.registry_dirs)), 'folder')}"
    )


def _physical_problems(tasks: list[tuple[Path, Any, TaskSpec]]) -> list[str]:
    """``file:line: field: message`` for every problem :func:`scene_problems` finds in ``tasks``."""
    problems: list[str] = []
    with show_progress("building scenes", "tasks") as progress:
        progress.start(len(tasks))
        for path, doc, spec in tasks:
            problems += [format_problem(str(path), doc, loc, msg) for loc, msg in scene_problems(spec)]
            progress.update(advance=1)
    return problems


def _name_from_id(task_id: str) -> str:
    short = task_id.split("/", 1)[1].rsplit("-v", 1)[0]
    words = re.sub(r"(?<!^)(?=[A-Z])", " ", short).split()
    return " ".join([words[0], *(w.lower() for w in words[1:])]) if words else short


@app.command("new")
def new_task(
    new_id: Annotated[str, typer.Argument(help="New id, e.g. mylab/PickUpCryovial-v1.")],
    template: Annotated[
        str,
        typer.Option(
            "--from", help="A template (pick, place, close_lid, press_button) or an existing task id to copy."
        ),
    ],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="File or folder to write (default: ./<name>.yaml).")
    ] = None,
    instruction: Annotated[str | None, typer.Option("--instruction", help="Language instruction.")] = None,
    asset: Annotated[str | None, typer.Option("--asset", help="Main object's asset id (templates only).")] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
) -> None:
    """Create a task file from a template or by copying a registered task, validated before writing.

    Example: pipette tasks new mylab/PickUpCryovial-v1 --from pick --asset cryovial_2ml --out registry/
    """
    if not re.match(TASK_ID_PATTERN, new_id):
        raise PipetteError(f"task id {new_id!r} must look like namespace/Name-v1 (e.g. mylab/PickUpCryovial-v1)")
    registry = _registry()
    if new_id in registry.tasks:
        raise PipetteError(f"task id {new_id!r} is already registered ({registry.entry(new_id).path})")
    name = _name_from_id(new_id)
    if template in task_template_names():
        context: dict[str, object] = {
            "task_id": new_id,
            "name": name,
            "instruction": instruction or f"{name}.",
            "robot": DEFAULT_ROBOT,
            "initial_joints": robot_spec(DEFAULT_ROBOT).arm.home,
        }
        if asset:
            context["asset"] = asset
        text = render_task_template(template, **context)
    else:
        if template not in registry.tasks and "/" not in template and not re.search(r"[A-Z]", template):
            raise PipetteError(
                f"unknown template {template!r}; {suggest(template, task_template_names())} "
                "(or give a registered task id to copy)"
            )
        source = registry.entry(template)
        doc = read_yaml(source.path)
        doc["id"] = new_id
        doc["name"] = name
        if "tags" in doc:  # a copy is not one of the paper's twelve benchmark tasks
            doc["tags"] = [t for t in doc["tags"] if t != "paper-benchmark"]
        if instruction:
            doc["instruction"] = instruction
        text = dump_yaml(doc)
    stem = re.sub(r"(?<!^)(?=[A-Z])", "_", new_id.split("/", 1)[1].rsplit("-v", 1)[0]).lower()
    target = out or Path(f"{stem}.yaml")
    if target.is_dir() or target.suffix not in YAML_SUFFIXES:
        target = target / f"{stem}.yaml"  # a folder, existing or to be made
    if target.exists() and not force:
        raise PipetteError(f"{target} exists; pass --force to overwrite")
    validate_task_document(parse_yaml(text, str(target)), str(target))
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(text, encoding="utf-8")
    err_console.print(wrote_task_line(target, new_id, verify="VERIFY" in text), markup=False, soft_wrap=True)
