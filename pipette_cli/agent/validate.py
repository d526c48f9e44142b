"""The one validator every plan goes through, whoever wrote it (offline parser or LLM).

:meth:`Validator.check` takes a :class:`PlanSpec` and returns a :class:`CheckedPlan`, or raises
an :class:`AgentError` saying what is wrong (which an LLM backend sends back to the model):

* each command must be in the catalog and each argument one of its parameters (``--image-size``
  and ``image-size`` are read as ``image_size``);
* values are typed as the CLI types them (int, float, bool, path, choices, ranges); task names
  become registered ids; a policy the CLI cannot train is :class:`Unsupported`;
* ``{"from_step": N}`` must point to an earlier step that makes something;
* the plan is completed: an input left empty takes the output of the latest earlier step of
  the kind it reads (augment's ``--input`` the file ``collect`` wrote), values such as the task
  and dataset version carry over to later steps, and the vocabulary's defaults fill required
  outputs (``collect --out data/<Task>.h5``);
* what is still missing is listed per step (a plan with missing values is never run).
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path
from typing import Any

from pipette_cli.agent.accounting import Accountant
from pipette_cli.agent.catalog import AgentError, CommandCatalog, CommandInfo, ParamInfo, Unsupported, is_empty
from pipette_cli.agent.plan import CheckedPlan, CheckedStep, Context, PlanSpec, StepRef
from pipette_cli.agent.products import product_of, version_in_path
from pipette_cli.agent.tasks import TaskIndex, task_in_file_name
from pipette_cli.agent.vocabulary import WorkflowVocabularySpec
from pipette_cli.demos.store import scan
from pipette_cli.errors import PipetteError, suggest
from pipette_cli.language.lexicon import short_name
from pipette_cli.language.phrases import phrase_pattern, words_of
from pipette_cli.registry import Registry

_TRUE, _FALSE = {"true", "yes", "1", "on"}, {"false", "no", "0", "off"}


class Validator:
    """Checks and completes plans against the catalog, the registry and the vocabulary."""

    def __init__(
        self, catalog: CommandCatalog, registry: Registry, vocab: WorkflowVocabularySpec, index: TaskIndex | None = None
    ) -> None:
        self.catalog = catalog
        self.registry = registry
        self.vocab = vocab
        self.accountant = Accountant(catalog, vocab, index or TaskIndex(registry, vocab))

    def check(self, plan: PlanSpec, *, request: str = "", context: Context | None = None) -> CheckedPlan:
        """Validate and complete ``plan`` (see the module docstring).

        Raises:
            AgentError: an unknown command, parameter, task or value; a bad step reference.
            Unsupported: a value Pipette does not support (e.g. a policy it cannot train).
        """
        self.refuse_unsupported_request(request)
        steps: list[CheckedStep] = []
        carried: dict[str, Any] = {"task": context.task} if context and context.task else {}
        for index, raw in enumerate(plan.steps, 1):
            where = f"step {index} ({raw.command})" if len(plan.steps) > 1 else raw.command
            info = self.catalog.get(raw.command)
            args: dict[str, Any] = {}
            for key, value in raw.args.items():
                param = self._param(info, key, where)
                if value is None or value == "" or value == []:
                    continue
                args[param.name] = self._value(info, param, value, index, steps, where)
            notes: list[str] = []
            self._link(info, args, steps, context, notes)
            task = self._carry(info, args, carried, steps, notes)
            self._templates(args, task)
            self._defaults(info, args, task, notes, {step.product for step in steps if step.product})
            missing = self.catalog.missing(info.name, args)
            product, kind = product_of(info, args, task, self.vocab)
            if product and "overwrite" in info.params and not args.get("overwrite") and Path(product).exists():
                notes.append(f"{product} exists: this step stops unless you say 'overwrite' (or leave it out)")
            steps.append(CheckedStep(index, info.name, args, missing, product, kind, notes))
            if task:
                carried["task"] = task
            for name in (*self.vocab.carry, *self.vocab.carry_to):
                if name != "task" and name in args:
                    carried[name] = args[name]
        checked = CheckedPlan(steps, request)
        return replace(checked, unused=self.accountant.unused_words(request, checked)) if request else checked

    # -- one argument -------------------------------------------------------------------------

    def _param(self, info: CommandInfo, key: str, where: str) -> ParamInfo:
        name = key.strip().lstrip("-").replace("-", "_")
        if name in info.params:
            return info.params[name]
        by_flag = {(p.flag or "").lstrip("-").replace("-", "_"): p for p in info.params.values() if p.flag}
        if name in by_flag:
            return by_flag[name]
        raise AgentError(f"{where}: 'pipette {info.name}' has no parameter {key!r}; {suggest(name, info.params)}")

    def _value(
        self, info: CommandInfo, param: ParamInfo, value: Any, index: int, steps: list[CheckedStep], where: str
    ) -> Any:
        label = f"{where}: {param.flag or param.name}"
        if isinstance(value, list) and not param.multiple:
            if len(value) != 1 and param.kind != "task":
                raise AgentError(f"{label} takes one value, not {len(value)}")
            value = value[0] if len(value) == 1 else value
        if isinstance(value, StepRef) or (isinstance(value, dict) and "from_step" in value):
            ref = value if isinstance(value, StepRef) else StepRef.model_validate(value)
            if not (param.path or param.address):
                raise AgentError(
                    f"{label} is not a file, folder or address; it cannot take step {ref.from_step}'s output"
                )
            if ref.from_step >= index:
                raise AgentError(f"{label}: a step can only use an earlier step's output, not step {ref.from_step}'s")
            if steps[ref.from_step - 1].product is None:
                raise AgentError(
                    f"{label}: step {ref.from_step} ({steps[ref.from_step - 1].command}) makes no file or folder to use"
                )
            return [ref] if param.multiple else ref
        if param.kind == "task":
            return self._task(info, param, value, label)
        if param.multiple:
            values = value if isinstance(value, list) else [value]
            return [self._value(info, _single(param), v, index, steps, where) for v in values]
        value = self._scalar(param, value, label)
        if param.parse is not None and isinstance(value, str):  # the CLI's own check, before anything runs
            try:
                param.parse(value)
            except PipetteError as e:
                raise AgentError(f"{where}: {e}") from None
        return value

    def _scalar(self, param: ParamInfo, value: Any, label: str) -> Any:
        try:
            if param.kind == "int":
                number = float(value)
                if number != int(number):
                    raise ValueError
                value = int(number)
            elif param.kind == "float":
                value = float(str(value).rstrip("%")) / (100 if str(value).endswith("%") else 1)
            elif param.kind == "bool":
                if isinstance(value, str):
                    if value.lower() not in _TRUE | _FALSE:
                        raise ValueError
                    value = value.lower() in _TRUE
                value = bool(value)
            else:
                value = str(value).strip()
        except (TypeError, ValueError):
            raise AgentError(
                f"{label} takes {'an' if param.kind == 'int' else 'a'} {param.kind}, not {value!r}"
            ) from None
        if isinstance(value, int | float) and not isinstance(value, bool):
            if param.minimum is not None and value < param.minimum:
                raise AgentError(f"{label} must be >= {param.minimum:g}, not {value:g}")
            if param.maximum is not None and value > param.maximum:
                raise AgentError(f"{label} must be <= {param.maximum:g}, not {value:g}")
        if isinstance(value, str):
            value = self._choice(param, value, label)
        return value

    def refuse_unsupported_request(self, request: str) -> None:
        """Raise :class:`Unsupported` when ``request`` asks for what no command does (vocabulary
        ``unsupported``: "push the dataset to the Hub")."""
        said = words_of(request)
        for phrase, reason in self.vocab.unsupported.items():
            if phrase_pattern(phrase).search(said):
                raise Unsupported(reason)

    def refuse_unsupported_policy(self, policy: str) -> None:
        """Raise :class:`Unsupported` when no command takes ``policy`` (a vocabulary policy key)."""
        for info in self.catalog.commands.values():
            for param in info.params.values():
                if set(param.values()) & set(self.vocab.policies):
                    self._choice(param, policy, param.flag or param.name)
                    return

    def _choice(self, param: ParamInfo, value: str, label: str) -> str:
        """A value of a parameter with listed values: the CLI's spelling, or a clear refusal."""
        policies = self.vocab.policies
        allowed = param.values()
        policy = next((key for word, key in self.vocab.policy_words() if value.lower() == word), None)
        if allowed and set(allowed) & set(policies) and policy is not None:  # a policy-valued option
            if policy not in allowed:
                names = ", ".join(policies[a].name if a in policies else a for a in allowed)
                raise Unsupported(f"{policies[policy].name} is not supported; supported are {names}")
            return policy
        if param.choices:
            lowered = {c.lower(): c for c in param.choices}
            if value.lower() not in lowered:
                raise AgentError(f"{label} must be one of {', '.join(param.choices)}, not {value!r}")
            return lowered[value.lower()]
        return value

    def _task(self, info: CommandInfo, param: ParamInfo, value: Any, label: str) -> Any:
        names = value if isinstance(value, list) else [v for v in re.split(r"\s*,\s*", str(value)) if v]
        if any(str(n).lower() == "all" for n in names):
            if "`all`" in param.help:
                return "all"
            if not param.required:
                return None  # the command's default covers every task
            instead = self.vocab.stands_in.get(info.name, {}).get(param.name)
            suite = info.params[instead].flag if instead in info.params else None
            raise AgentError(
                f"'pipette {info.name}' runs one task at a time; name the task"
                + (f", or run a suite of tasks with {suite}" if suite else "")
            )
        try:
            ids = [self.registry.entry(str(n).strip()).spec.id for n in names]
        except PipetteError as exc:
            raise AgentError(f"{label}: {exc}") from None
        if param.multiple:
            return ids
        if len(ids) > 1 and not param.comma_list:
            raise AgentError(f"'pipette {info.name}' runs one task at a time; name one of {', '.join(ids)}")
        return ",".join(ids)

    # -- completing a step --------------------------------------------------------------------

    def _link(
        self,
        info: CommandInfo,
        args: dict[str, Any],
        steps: list[CheckedStep],
        context: Context | None,
        notes: list[str],
    ) -> None:
        """Empty inputs take the latest earlier output of the kind they read; an input that is an
        earlier step's output takes the values that output sets (an augmented file is
        ``dataset_version: augmented``)."""
        self._take_over(info, args, steps)
        choice = self.catalog.one_of.get(info.name, ())
        chosen = any(not is_empty(args.get(c)) for c in choice)
        wanted = {
            p: self.vocab.consumes[f"{info.name}.{p}"]
            for p in info.params
            if f"{info.name}.{p}" in self.vocab.consumes
            and is_empty(args.get(p))
            and (
                info.params[p].required
                or (p in choice and not chosen)
                or info.is_answer
                or f"{info.name}.{p}" in self.vocab.links_optional
            )
        }
        for step in reversed(steps):  # what a step made, else the file it read ("inspect x.h5, then augment it")
            offers: list[tuple[str | None, Any]] = [(step.product_kind, StepRef(from_step=step.index))]
            offers += [
                (kind, step.args[p])
                for key, kind in self.vocab.consumes.items()
                for command, _, p in [key.rpartition(".")]
                if command == step.command
                and isinstance(step.args.get(p), str | list)
                and not any(isinstance(v, StepRef) for v in (step.args[p] if isinstance(step.args[p], list) else []))
            ]
            sets = self._sets(step.command)
            if any(not is_empty(args.get(k)) and args[k] != v for k, v in sets.items()):
                offers = offers[1:]  # "convert the raw data": not what augment made
            for kind, value in offers:
                param = next((p for p, wants in wanted.items() if wants == kind), None)
                if param is None or kind is None:
                    continue
                many = info.params[param].multiple
                args[param] = (
                    (value if isinstance(value, list) else [value])
                    if many
                    else (value[0] if isinstance(value, list) else value)
                )
                self._take_over(info, args, steps)
                return
        for param, kind in wanted.items():
            if context and kind in context.products:
                path = context.products[kind]
                args[param] = [path] if info.params[param].multiple else path
                notes.append(f"{param} from the previous request: {path}")
                return

    def _carry(
        self,
        info: CommandInfo,
        args: dict[str, Any],
        carried: dict[str, Any],
        steps: list[CheckedStep],
        notes: list[str],
    ) -> str | None:
        """Fill values earlier steps set (task, dataset version...); return the step's task."""
        param = info.task_param()
        inferred = self._task_of_files(info, args)
        if (
            param is not None
            and is_empty(args.get(param.name))
            and (param.required or (steps and not _reads_a_step(args)))  # "render X, then check its expert"
            and (inferred or carried.get("task"))
        ):
            task = inferred or carried["task"]
            args[param.name] = [task] if param.multiple else task
            if inferred:
                notes.append(f"task of the input file: {inferred}")
            elif not steps:
                notes.append(f"task from the previous request: {task}")
        for name in self.vocab.carry:
            if name in info.params and is_empty(args.get(name)) and name in carried:
                args[name] = carried[name]
        for name, commands in self.vocab.carry_to.items():
            if info.name in commands and name in info.params and is_empty(args.get(name)) and name in carried:
                args[name] = carried[name]
        task = args.get(param.name) if param is not None else None
        if isinstance(task, list):
            task = task[0] if len(task) == 1 else None
        if isinstance(task, str) and task != "all" and "," not in task:
            return task
        return (inferred or carried.get("task")) if param is None else None

    def _task_of_files(self, info: CommandInfo, args: dict[str, Any]) -> str | None:
        """The task of a demo file the step reads: the file's own record if it exists, else a
        registered task name in its file name (``data/PickUpTestTube_augmented.h5``)."""
        for param in info.params.values():
            if not param.path or param.writes:
                continue
            value = args.get(param.name)
            for path in value if isinstance(value, list) else [value]:
                if not isinstance(path, str) or not path.endswith((".h5", ".hdf5")):
                    continue
                if Path(path).is_file():
                    try:
                        status = scan(Path(path))
                    except PipetteError:
                        status = None
                    if status is not None and status.info is not None and status.info.task_id in self.registry.tasks:
                        return status.info.task_id
                named = task_in_file_name(path, self.registry.ids())
                if named:
                    return named
        return None

    def _sets(self, command: str) -> dict[str, str]:
        """What ``command``'s output tells a step that reads it (``augment``: ``dataset_version: augmented``)."""
        return self.vocab.products[command].sets if command in self.vocab.products else {}

    def _take_over(self, info: CommandInfo, args: dict[str, Any], steps: list[CheckedStep]) -> None:
        """Empty values of ``args`` that the earlier outputs it reads set, or a policy folder in
        ``train``'s layout (``..._augmented/checkpoints/...``: ``dataset_version: augmented``)."""
        for name, kind in self.vocab.consumed(info.name).items():
            version = version_in_path(args[name]) if kind == "policy" and isinstance(args.get(name), str) else None
            if version and "dataset_version" in info.params and is_empty(args.get("dataset_version")):
                args["dataset_version"] = version
        for value in list(args.values()):
            for ref in value if isinstance(value, list) else [value]:
                if isinstance(ref, StepRef):
                    sets = self._sets(steps[ref.from_step - 1].command)
                    args.update({k: v for k, v in sets.items() if k in info.params and is_empty(args.get(k))})

    def _templates(self, args: dict[str, Any], task: str | None) -> None:
        """``{Task}`` and ``{policy}`` in a value (a workflow's output folders) filled in; a value
        whose name is still unknown is left out (a default or the missing list takes over)."""
        policy = args.get("policy") if isinstance(args.get("policy"), str) else args.get("policy_type")
        names = {"Task": short_name(task) if task else None, "policy": policy}
        for key, value in list(args.items()):
            if isinstance(value, str) and re.search(r"\{(?:Task|policy)\}", value):
                if any(f"{{{k}}}" in value and not v for k, v in names.items()):
                    del args[key]
                else:
                    args[key] = value.format(**names)

    def _defaults(
        self, info: CommandInfo, args: dict[str, Any], task: str | None, notes: list[str], taken: set[str]
    ) -> None:
        """Fill the vocabulary's default outputs; one an earlier step of the plan already writes gets
        the step's robot or policy folder's name, else a number ("10 on the Franka and 10 on the UR5e":
        two files)."""
        suite = args.get("suite_id")
        known = {
            "Task": short_name(task) if task else None,
            "Suite": short_name(suite) if isinstance(suite, str) else None,
        }
        for key, templates in self.vocab.defaults.items():
            command, _, name = key.rpartition(".")
            if command != info.name or name not in info.params or not is_empty(args.get(name)):
                continue
            filled = [
                t.format(**known)
                for t in ([templates] if isinstance(templates, str) else templates)
                if all(known.get(k) for k in re.findall(r"\{(\w+)\}", t))
            ]
            if not filled:
                continue
            path = filled[0]
            stem, dot, suffix = path.rpartition(".") if "." in path.rsplit("/", 1)[-1] else (path, "", "")
            tags = [str(args["robot"])] if args.get("robot") else []
            tags += [Path(args["policy"]).name] if isinstance(args.get("policy"), str) else []  # eval's policy folder
            tags += [str(n) for n in range(2, len(taken) + 3)]
            for tag in tags:
                if path not in taken:
                    break
                path = f"{stem}_{tag}{dot}{suffix}"
            args[name] = path
            notes.append(f"default {info.params[name].flag or name} {args[name]}")


def _single(param: ParamInfo) -> ParamInfo:
    return replace(param, multiple=False)


def _reads_a_step(args: dict[str, Any]) -> bool:
    """Whether a step reads an earlier step's product (``@N``): it then has its task from that input."""
    values = [v for value in args.values() for v in (value if isinstance(value, list) else [value])]
    return any(isinstance(v, StepRef) for v in values)
