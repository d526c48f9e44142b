"""``pipette new-task``: description -> plan -> checked plan -> composed task -> YAML -> built task.

The same path serves every backend. The offline backend parses the description into a
:class:`~pipette_cli.taskgen.plan.TaskPlanSpec`; an LLM backend fills the same model through
structured output. A plan is accepted only when it validates (:mod:`pipette_cli.taskgen.validate`), composes, renders
to YAML that the registry's own rules accept, builds, and passes the caller's ``gate`` (``--check``).
LLM backends are sent every rejection back for a corrected answer, a bounded number of times;
what cannot be simulated (liquids, screwing caps) is refused before any request.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from pipette_cli.authoring.backends import AuthoringBackend
from pipette_cli.authoring.clause import ClauseReader
from pipette_cli.authoring.refusals import refuse_unknown, refuse_unsupported
from pipette_cli.authoring.text import normalise, split_steps, tokenise
from pipette_cli.errors import PipetteError, SimError, SpecError
from pipette_cli.language.assets import Vocabulary, load_vocabulary
from pipette_cli.registry import Registry, validate_task_document
from pipette_cli.sim.world import World
from pipette_cli.specs.robot import DEFAULT_ROBOT, robot_names
from pipette_cli.specs.task import TASK_ID_PATTERN, TaskSpec
from pipette_cli.specs.yaml_io import dump_yaml, parse_yaml
from pipette_cli.taskgen.check import check_task
from pipette_cli.taskgen.compose import ComposedTask, compose
from pipette_cli.taskgen.measure import measure_asset
from pipette_cli.taskgen.plan import PlanError, TaskPlanSpec, plan_json_schema
from pipette_cli.taskgen.render import environment, render_task
from pipette_cli.taskgen.resolve import Wanted, candidates
from pipette_cli.taskgen.validate import CheckedPlan, separate_lid, validate_plan

if TYPE_CHECKING:
    from pipette_cli.taskgen.check import CheckReport

PROMPT_TEMPLATE = "prompts/task_draft.md.j2"
Gate = Callable[["DraftedTask"], None]
"""Called on a built draft; raises :class:`PlanError` to reject it (``--check``)."""


@dataclass
class DraftedTask:
    """A drafted task that validates and builds; nothing is written yet."""

    description: str
    backend: str
    plan: TaskPlanSpec
    composed: ComposedTask
    yaml_text: str
    spec: TaskSpec
    remarks: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    """What the user is told about choices made for them (another robot than the default)."""
    not_understood: list[str] = field(default_factory=list)
    """Words of the description the plan does not use: shown with the draft; ``--yes`` does not write it."""
    report: CheckReport | None = None
    """What the ``--check`` gate found (None without it)."""

    def target_path(self, out: Path | None) -> Path:
        """Where ``--out`` (a file or a folder) puts this task (default: ./<stem>.yaml)."""
        target = out or Path(f"{self.composed.file_stem}.yaml")
        if target.is_dir() or target.suffix not in (".yaml", ".yml"):
            target = target / f"{self.composed.file_stem}.yaml"
        return target


@dataclass(frozen=True)
class DraftOptions:
    """How a plan becomes a task, the same for every attempt of one :func:`draft_task`.

    Attributes:
        namespace: Namespace of the id derived from the plan.
        task_id: The id to use instead of the derived one.
        registry: Whose ids are taken (None: no check).
        build: Build the task's world (compile, layout checks) before accepting it.
        gate: Called on the built draft; raises :class:`PlanError` to reject it (``--check``).
    """

    namespace: str = "generated"
    task_id: str | None = None
    registry: Registry | None = None
    build: bool = True
    gate: Gate | None = None


def task_prompt(vocab: Vocabulary) -> str:
    """The system prompt for LLM backends: the plan's fields, an example, and every asset id."""
    ids = sorted(vocab.assets)
    return (
        environment()
        .get_template(PROMPT_TEMPLATE)
        .render(
            robots=robot_names(),
            graspable=[a for a in ids if vocab.assets[a].graspable],
            fixed=[a for a in ids if not vocab.assets[a].graspable],
        )
    )


def finish_plan(
    plan: TaskPlanSpec,
    description: str,
    backend: str,
    *,
    vocab: Vocabulary,
    options: DraftOptions = DraftOptions(),
    remarks: tuple[str, ...] = (),
    not_understood: tuple[str, ...] = (),
) -> DraftedTask:
    """Validate, compose, render, check against the registry rules, build and gate one plan.

    ``remarks`` become VERIFY notes (the offline parser's choices among equal assets);
    ``not_understood`` are the description's words the plan does not use.

    Raises:
        PlanError: the plan is impossible (each problem says what to change), the id is taken, or
            the task fails to build or to pass ``gate``.
    """
    checked = validate_plan(plan, vocab, partial(resolve_asset, vocab=vocab))
    registry = options.registry
    composed = compose(checked, namespace=options.namespace, task_id=options.task_id, remarks=remarks)
    if not re.match(TASK_ID_PATTERN, composed.task_id):
        raise PlanError(f"task id {composed.task_id!r} must look like namespace/Name-v1")
    if registry is not None and composed.task_id in registry.tasks:
        raise PlanError(
            f"task id {composed.task_id!r} is already registered ({registry.entry(composed.task_id).path}); "
            "pass --id to name the new task"
        )
    text = render_task(composed, description=description, backend=backend)
    source = f"<draft {composed.file_stem}.yaml>"
    try:
        doc = parse_yaml(text, source)
        spec = validate_task_document(doc, source)
    except SpecError as exc:
        raise PlanError(
            ["the drafted YAML does not validate (a bug in the template or composition):", *exc.problems]
        ) from None
    text = dump_yaml(doc)  # the registry's house style, so the file round-trips through ruamel unchanged
    drafted = DraftedTask(
        description, backend, checked.plan, composed, text, spec, list(remarks), not_understood=list(not_understood)
    )
    if options.build:
        try:
            World(spec)
        except SimError as exc:
            raise PlanError(f"impossible layout: the drafted scene does not build: {exc}") from None
    if options.gate is not None:
        options.gate(drafted)
    return drafted


def resolve_asset(words: str, vocab: Vocabulary) -> str:
    """An asset id for ``words``: the id itself, or the asset its words name ("the 15 mL falcon tube").

    Raises:
        PlanError: nothing in the library is called that ("unknown object 'X'; nearest: ...").
    """
    if words in vocab.assets:
        return words
    text = normalise(words.replace("_", " "), vocab.words)
    clause = ClauseReader(vocab).read(tokenise(text, vocab))
    found = [m for m in clause.mentions if not m.is_bench and not m.is_pronoun]
    if found:
        m = found[-1]
        return candidates(vocab, Wanted(m.kind, tuple(m.sizes), tuple(m.modifiers)))[0]
    nearest = vocab.nearest(words.replace("_", " "))
    hint = ", ".join(nearest) if nearest else "nothing similar (see `pipette assets list`)"
    raise PlanError(f"unknown object '{words}'; nearest: {hint}")


def screen(description: str, vocab: Vocabulary) -> tuple[dict[str, str], list[str]]:
    """Refuse what no plan can do before asking an LLM (liquids, caps...: final), and return the
    kinds of object the description names (an LLM's plan may only use those) with their words as
    written, and the words nothing in the lexicon explains (not understood, whatever the plan)."""
    reader = ClauseReader(vocab)
    clauses = [reader.read(part) for part in split_steps(normalise(description, vocab.words), reader.is_verb, vocab)]
    refuse_unsupported(clauses, vocab)
    named = {m.kind: m.words() for c in clauses for m in c.mentions if not m.is_bench and not m.is_pronoun}
    named |= {c.implied_target: c.verb or c.implied_target for c in clauses if c.implied_target}
    if not named:
        refuse_unknown(clauses, vocab)
        raise PlanError(
            "found no object of the asset library in the description; name one (see `pipette assets list`)", final=True
        )
    return named, refuse_unknown(clauses, vocab, refuse=False)


def unused_names(checked: CheckedPlan, named: dict[str, str]) -> list[str]:
    """The words of the objects the description names that an LLM's plan leaves out."""
    used = {kind for obj in checked.objects.values() for kind in obj.info.kinds}
    return [words for kind, words in named.items() if kind not in used]


def grounding_problems(checked: CheckedPlan, kinds: set[str], vocab: Vocabulary) -> list[str]:
    """Objects of an LLM's plan that the description does not name."""
    named = {a for k in kinds for a in vocab.members(k)}
    lids = {separate_lid(measure_asset(a)) for a in named if vocab.assets[a].static}
    problems = []
    for name, obj in checked.objects.items():
        if obj.asset not in named and obj.asset not in lids:
            problems.append(
                f"objects: {name!r} is {obj.asset}, but the description names no "
                f"{obj.info.kinds[0] if obj.info.kinds else obj.asset}; use only the objects it names "
                f"({', '.join(sorted(kinds))})"
            )
    return problems


def on_a_robot_that_can(plan: TaskPlanSpec, finish: Callable[[TaskPlanSpec], DraftedTask]) -> DraftedTask:
    """``finish(plan)``; when the plan names no robot and the default cannot do it for a limit of
    its own (reach, gripper opening, payload), the first registered robot that can, said in the
    draft's notes.

    Raises:
        PlanError: the default robot's problem when it is no robot limit; else every robot's limit.
    """
    try:
        return finish(plan)
    except PlanError as exc:
        if plan.robot is not None or not exc.robot_limit:
            raise
        tried = [(DEFAULT_ROBOT, exc.problems[0])]
    for robot in (r for r in robot_names() if r != DEFAULT_ROBOT):
        try:
            drafted = finish(plan.model_copy(update={"robot": robot}))
        except PlanError as exc:
            tried.append((robot, exc.problems[0]))
            continue
        drafted.notes.append(
            f"drafted for the {robot}, the first robot that can: the {tried[0][0]} cannot ({tried[0][1]})"
        )
        return drafted
    said = "; ".join(f"the {robot}: {problem}" for robot, problem in tried)
    raise PlanError(f"no registered robot can do this: {said}", robot_limit=True)


def draft_task(
    description: str,
    backend: AuthoringBackend,
    *,
    namespace: str = "generated",
    task_id: str | None = None,
    registry: Registry | None = None,
    build: bool = True,
    gate: Gate | None = None,
) -> DraftedTask:
    """Turn ``description`` into a :class:`DraftedTask` with ``backend``.

    Raises:
        PlanError: the description cannot become a task (says why).
        BackendError: an LLM backend gave no acceptable answer within its attempts.
    """
    if not description.strip():
        raise PlanError("the description is empty; say what the robot should do, e.g. 'Pick up the test tube'")
    vocab = load_vocabulary()
    options = DraftOptions(namespace=namespace, task_id=task_id, registry=registry, build=build, gate=gate)
    parsed = backend.parse_task(description)
    if parsed is not None:
        return on_a_robot_that_can(
            parsed.plan,
            partial(
                finish_plan,
                description=description,
                backend=backend.name,
                vocab=vocab,
                options=options,
                remarks=tuple(parsed.remarks),
                not_understood=tuple(parsed.not_understood),
            ),
        )
    named, unknown = screen(description, vocab)

    def accept(plan: TaskPlanSpec) -> DraftedTask:
        checked = validate_plan(plan, vocab, partial(resolve_asset, vocab=vocab))
        problems = grounding_problems(checked, set(named), vocab)
        if problems:
            raise PlanError(problems)
        unused = (*unknown, *unused_names(checked, named))
        finish = partial(
            finish_plan,
            description=description,
            backend=backend.name,
            vocab=vocab,
            options=options,
            not_understood=unused,
        )
        return on_a_robot_that_can(plan, finish)

    return backend.complete(
        system=task_prompt(vocab),
        user=f"Task: {description}",
        schema=TaskPlanSpec,
        accept=accept,
        json_schema=plan_json_schema(list(vocab.assets)),
    )


def check_gate(episodes: int, *, enforce: bool = True) -> Gate:
    """The ``--check`` gate: build, an idle rollout that must not succeed, and the expert on
    ``episodes`` seeds (at least 4 of 5 must succeed). The report is kept on the draft; with
    ``enforce`` a failed check raises :class:`PlanError` naming the stage and step that failed (an
    LLM backend is sent it for a corrected answer)."""

    def gate(drafted: DraftedTask) -> None:
        report = check_task(drafted.spec, episodes, stage_names=drafted.composed.stage_names)
        drafted.report = report
        if not enforce:
            return
        if not report.ok:
            raise PlanError(f"--check failed for {drafted.spec.id}: {'; '.join(report.problems)}")
        if report.solve.status != "solved":
            raise PlanError(f"--check failed for {drafted.spec.id}: {report.solve.summary()}")

    return gate


def plan_summary(checked: CheckedPlan) -> list[str]:
    """The plan in one line per step: ``action object-asset [relation] [target-or-source-asset]``."""
    lines = []
    for step in checked.steps:
        other = step.target or (step.source if step.action == "remove" else None)
        words = [step.action, checked.asset(step.object), *([step.relation] if step.relation else [])]
        words += [checked.asset(other)] if other else []
        lines.append(" ".join(words))
    return lines


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
