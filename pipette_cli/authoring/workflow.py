"""``pipette new-task``: description -> draft -> plan -> YAML -> validated, built task.

The same path serves every backend: the backend produces a :class:`TaskDraftSpec`; the
draft is accepted only when it composes, renders, validates against the registry rules and
its scene builds. LLM backends re-ask with the problems of a rejected draft.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from pipette_cli.authoring.backends import AuthoringBackend
from pipette_cli.authoring.compose import TaskPlan, compose
from pipette_cli.authoring.draft import INTENTS, ROLES_BY_INTENT, DraftError, TaskDraftSpec
from pipette_cli.authoring.render import environment, render_plan
from pipette_cli.authoring.vocabulary import Vocabulary, load_vocabulary
from pipette_cli.errors import PipetteError, SimError, SpecError
from pipette_cli.registry import Registry, validate_task_document
from pipette_cli.specs.robot import DEFAULT_ROBOT, robot_names
from pipette_cli.specs.task import TASK_ID_PATTERN, TaskSpec
from pipette_cli.specs.yaml_io import dump_yaml, parse_yaml

PROMPT_TEMPLATE = "prompts/task_draft.md.j2"


@dataclass
class DraftedTask:
    """A drafted task that validates and builds; nothing is written yet."""

    description: str
    backend: str
    draft: TaskDraftSpec
    plan: TaskPlan
    yaml_text: str
    spec: TaskSpec

    def target_path(self, out: Path | None) -> Path:
        """Where ``--out`` (a file or a folder) puts this task (default: ./<stem>.yaml)."""
        target = out or Path(f"{self.plan.file_stem}.yaml")
        if target.is_dir() or target.suffix not in (".yaml", ".yml"):
            target = target / f"{self.plan.file_stem}.yaml"
        return target


def task_prompt(vocab: Vocabulary) -> str:
    """The system prompt for LLM backends: intents, roles, robots and every asset."""
    assets = [{"id": a, "description": i.description, "graspable": i.graspable,
               "sites": [s for s in i.semantics.get("sites", []) if not re.match(r"slot_([1-9]|\d\d)", s)],
               "joints": i.semantics.get("joints", [])}
              for a, i in sorted(vocab.assets.items()) if a != "lab_bench"]
    return environment().get_template(PROMPT_TEMPLATE).render(
        intents=INTENTS, roles_by_intent=ROLES_BY_INTENT, robots=robot_names(), default_robot=DEFAULT_ROBOT,
        assets=assets)


def finish_draft(draft: TaskDraftSpec, description: str, backend: str, *, vocab: Vocabulary,
                 namespace: str = "generated", task_id: str | None = None, remarks: tuple[str, ...] = (),
                 registry: Registry | None = None, build: bool = True) -> DraftedTask:
    """Compose, render, validate and build one draft.

    Raises:
        DraftError: the draft is impossible (unknown assets, no room, ...), the id is taken, or
            the generated YAML fails validation or does not build (each with the reason).
    """
    plan = compose(draft, vocab, namespace=namespace, task_id=task_id, remarks=remarks)
    if not re.match(TASK_ID_PATTERN, plan.task_id):
        raise DraftError(f"task id {plan.task_id!r} must look like namespace/Name-v1")
    if registry is not None and plan.task_id in registry.tasks:
        raise DraftError(f"task id {plan.task_id!r} is already registered ({registry.entry(plan.task_id).path}); "
                         "pass --id to name the new task")
    text = render_plan(plan, description=description, backend=backend)
    source = f"<draft {plan.file_stem}.yaml>"
    try:
        doc = parse_yaml(text, source)
        spec = validate_task_document(doc, source)
    except SpecError as exc:
        raise DraftError(["the drafted YAML does not validate (a bug in the template or plan):", *exc.problems]) from None
    text = dump_yaml(doc)  # the registry's house style, so the file round-trips through ruamel unchanged
    if build:
        from pipette_cli.sim.world import World

        try:
            World(spec)
        except SimError as exc:
            raise DraftError(f"the drafted scene does not build: {exc}") from None
    return DraftedTask(description, backend, draft, plan, text, spec)


def draft_task(description: str, backend: AuthoringBackend, *, namespace: str = "generated", task_id: str | None = None,
               registry: Registry | None = None, build: bool = True) -> DraftedTask:
    """Turn ``description`` into a :class:`DraftedTask` with ``backend``.

    Raises:
        DraftError: the description cannot become a task (the offline backend says why).
        BackendError: an LLM backend gave no acceptable answer within its attempts.
    """
    if not description.strip():
        raise DraftError("the description is empty; say what the robot should do, e.g. 'Pick up the test tube'")
    vocab = load_vocabulary()
    options = dict(vocab=vocab, namespace=namespace, task_id=task_id, registry=registry, build=build)
    parsed = backend.parse_task(description)
    if parsed is not None:
        return finish_draft(parsed.draft, description, backend.name, remarks=tuple(parsed.remarks), **options)

    def accept(draft: TaskDraftSpec) -> DraftedTask:
        return finish_draft(draft, description, backend.name, **options)

    return backend.complete(system=task_prompt(vocab), user=f"Task description: {description}",
                            schema=TaskDraftSpec, accept=accept)


def write_task(drafted: DraftedTask, target: Path, *, force: bool = False) -> Path:
    """Write the YAML (only a validated draft gets here).

    Raises:
        PipetteError: the file exists and ``force`` is false.
    """
    if target.exists() and not force:
        raise PipetteError(f"{target} exists; pass --force to overwrite")
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(drafted.yaml_text, encoding="utf-8")
    return target
