"""The offline agent: a deterministic parser from a request to a :class:`PlanSpec`.

The request is split into clauses, one per command (:mod:`.clauses`); a clause asking for a
whole workflow becomes that recipe's steps; each clause's arguments are read from its words
(:mod:`.arguments`); a clause that only completes the step before ("save the picture to y.png")
or says what was done before ("after training") adds to that step or plans nothing. Every word
list comes from the vocabulary and every option from the CLI's catalog, so an option added to
the CLI is understood by the words of its own name. The plan then goes through the same
:class:`.validate.Validator` as an LLM's.
"""

from __future__ import annotations

import itertools
import re
from typing import Any

from pipette_cli.agent.arguments import ArgumentReader
from pipette_cli.agent.catalog import (
    AgentError,
    CommandCatalog,
    CommandInfo,
    Unsupported,
    is_empty,
)
from pipette_cli.agent.clauses import RECIPE_PREFIX, Clause, Intents, split_clauses
from pipette_cli.agent.mentions import option_words
from pipette_cli.agent.plan import CheckedPlan, Context, PlanSpec, StepSpec
from pipette_cli.agent.tasks import TaskIndex
from pipette_cli.agent.validate import Validator
from pipette_cli.agent.vocabulary import WEIGHTS, RecipeSpec, WorkflowVocabularySpec, distributed, lexicon
from pipette_cli.language.mentions import find_mentions
from pipette_cli.language.phrases import find_phrase, phrase_pattern, singular, words_of
from pipette_cli.registry import Registry


def one_path_each(text: str, names: list[str]) -> list[str]:
    """``text`` once per path of its lists of paths joined by "and" ("evaluate a/ and b/ ..., into
    c/ and d/": "evaluate a/ ..., into c/", "evaluate b/ ..., into d/"), when every such list has
    as many; else ``[]``."""
    paths = "|".join(re.escape(m.path) for m in sorted(find_mentions(text, names).paths, key=lambda m: -len(m.path)))
    if not paths:
        return []
    lists = list(re.finditer(rf"(?:{paths})(?:\s*(?:,|and|&|,\s*and)\s*(?:{paths}))+", text))
    items = [re.findall(paths, m.group(0)) for m in lists]
    if not items or len({len(i) for i in items}) != 1 or len(items[0]) < 2:
        return []
    out = []
    for k in range(len(items[0])):
        said, at = "", 0
        for m, listed in zip(lists, items, strict=True):
            said += text[at : m.start()] + listed[k]
            at = m.end()
        out.append(said + text[at:])
    return out


_QUOTED = re.compile(r"[\"“'‘](.+?)[\"”'’](?!\w)")


def _recipe_value(value: Any, before: int) -> Any:
    """A recipe's value in a plan that has ``before`` steps ahead of the recipe (its step
    references shifted; ``{Task}`` and ``{policy}`` are filled by the validator)."""
    if isinstance(value, list):
        return [_recipe_value(v, before) for v in value]
    if isinstance(value, dict) and "from_step" in value:
        return {"from_step": int(value["from_step"]) + before}
    return value


class OfflineAgent:
    """Deterministic request parser over the CLI catalog, the registry and the vocabulary."""

    name = "offline"

    def __init__(
        self, catalog: CommandCatalog, registry: Registry, vocab: WorkflowVocabularySpec | None = None
    ) -> None:
        self.catalog = catalog
        self.registry = registry
        self.vocab = vocab or lexicon(registry)
        self.index = TaskIndex(registry, self.vocab)
        self.validator = Validator(catalog, registry, self.vocab, self.index)
        self.intents = Intents(self.vocab, catalog, registry.ids())
        self.readers = self.vocab.readers()
        self.arguments = ArgumentReader(catalog, registry, self.vocab, self.index, self.intents, self.readers)

    def plan(self, text: str, context: Context | None = None) -> CheckedPlan:
        """The checked plan for ``text``.

        Raises:
            Unsupported: the request asks for something Pipette does not do (this comes first:
                "train diffusion on the lid task" says diffusion is not supported, not which lid).
            AgentError: nothing to run can be read from ``text``, a task is unknown or
                ambiguous, or a value is wrong (see :class:`.validate.Validator`).
        """
        try:
            spec, problems = self._read(text)
        except AgentError:  # a path or value it could not place: the unsupported policy still comes first
            self.validator.refuse_unsupported_request(text)
            policy = self.arguments.policy(words_of(text))
            if policy:
                self.validator.refuse_unsupported_policy(policy)
            raise
        if problems:
            try:
                self.validator.check(spec, request=text, context=context)
            except Unsupported:
                raise
            except AgentError:
                pass
            raise AgentError(problems[0])
        return self.validator.check(spec, request=text, context=context)

    def draft(self, text: str) -> PlanSpec:
        """The plan as read from the words, before validation."""
        spec, problems = self._read(text)
        if problems:
            raise AgentError(problems[0])
        return spec

    def _read(self, text: str) -> tuple[PlanSpec, list[str]]:
        steps: list[StepSpec] = []
        problems: list[str] = []
        clauses = split_clauses(self._corrected(text), self.intents)
        while clauses:
            clause = clauses.pop(0)
            if clause.command is not None and clause.command.startswith(RECIPE_PREFIX):
                recipe = self.vocab.recipes[
                    clause.command.removeprefix(RECIPE_PREFIX)
                ]  # "..., and compare them on the paper suite": one workflow
                own = {item.command for item in recipe.steps}
                said = [clause.text]
                while clauses and clauses[0].after != "strong" and clauses[0].command in own:
                    said.append(clauses.pop(0).text)
                steps += self._expand(recipe, ", ".join(said), len(steps), problems)
                continue
            command = clause.command or self._policy_only(clause.text)
            if command is None or (clauses and self._done_before(clause.text)):
                continue  # "after training, evaluate ...": what was done before, not a step
            command = self._about_asset(command, clause.text)
            info = self.catalog.get(command)
            try:
                args = self.arguments.fill(info, clause.text, problems)
            except AgentError:
                paired = one_path_each(clause.text, self.registry.ids())
                if not paired:
                    raise
                # "evaluate a/ and b/ ..., into c/ and d/": one step per path, paired in order
                clauses[:0] = [Clause(t, command, clause.score, "strong") for t in paired]
                continue
            self._same_as_before(info, clause.text, args, steps)
            if self._about_the_listing(info, clause, args, steps):
                continue  # "which suites are there, and how many episodes does each one have?": the listing says
            spread = distributed(find_mentions(clause.text, self.registry.ids()).words, self.vocab.distributes)
            both = self.arguments.both(info, words_of(spread))  # "the nominal and shifted suites": two steps
            if not both and self._continues(info, clause, args, steps):
                steps[-1].args.update(args)  # "render X. save the picture to y.png": one step
                continue
            each = [] if both else self._each_product(info, clause.text, args, steps)
            if each:  # "convert both": one step per earlier output of the kind it reads
                steps += [StepSpec(command=command, args={**args, **one}) for one in each]
                continue
            for value in both[1] if both else [None]:  # "convert both the raw and the augmented data"
                steps.append(StepSpec(command=command, args={**args, both[0]: value} if both else args))
        if not steps:
            filler = {w.lower() for w in self.vocab.filler}
            said = [w for w in words_of(find_mentions(text, self.registry.ids()).words).split() if w not in filler]
            asked = f" (nothing in {', '.join(map(repr, said[:6]))} names a command)" if said else ""
            if "new-task" in self.catalog and self.index.describes_work(text):  # "put the 15 mL tube in the rack"
                raise AgentError(
                    f"cannot tell what to run from this request{asked}; it reads as something for the robot to "
                    f"do: to make it a task, say 'new task: {text.strip()}' (pipette new-task \"...\"); to record "
                    "it, name a registered task ('collect 20 demos of PickUpTestTube')"
                )
            raise AgentError(
                f"cannot tell what to run from this request{asked}; say e.g. 'list the tasks', "
                "'collect 20 demos of PickUpTestTube', 'how many demos are in data/x.h5'"
            )
        return PlanSpec(steps=steps), problems

    def _about_the_listing(
        self, info: CommandInfo, clause: Clause, args: dict[str, Any], steps: list[StepSpec]
    ) -> bool:
        """Whether ``clause`` asks about each of the things the step before lists ("..., and how many
        episodes does each one have?") with an answer that has nothing of its own to read: no input
        given, and no earlier step makes the kind it reads. Such a clause is no step of its own."""
        if not info.is_answer or not steps or clause.after != "weak":
            return False
        made = {p.kind for s in steps if (p := self.vocab.products.get(s.command)) is not None}
        if any(not is_empty(args.get(param)) or kind in made for param, kind in self.vocab.consumed(info.name).items()):
            return False
        return find_phrase(self.vocab.each, words_of(clause.text)) is not None

    def _same_as_before(self, info: CommandInfo, text: str, args: dict[str, Any], steps: list[StepSpec]) -> None:
        """Options said to be "the same" ("on the same suite and task") take the value of the
        latest earlier step that set them."""
        for m in re.finditer(r"\bsame\s+([a-z]+(?:\s*(?:,|and|&)\s*[a-z]+)*)", words_of(text)):
            for word in re.split(r"\s*(?:,|and|&)\s*", m.group(1)):
                param = next((p for p in info.params.values() if singular(word) in option_words(p)), None)
                if param is None or not is_empty(args.get(param.name)):
                    continue
                before = next(
                    (s.args[param.name] for s in reversed(steps) if not is_empty(s.args.get(param.name))), None
                )
                if before is not None:
                    args[param.name] = before

    def _about_asset(self, command: str, text: str) -> str:
        """``command``, or the one the vocabulary's ``about_an_asset`` gives for it when ``text``
        names an asset and no task ("show me the spectrophotometer")."""
        other = self.vocab.about_an_asset.get(command)
        if other is None or other not in self.catalog:
            return command
        words = words_of(find_mentions(text, self.registry.ids()).words)
        task_words = find_phrase(self.vocab.refers.get("task", []), words)
        if task_words or self.index.names_a_task(words) or not self.arguments.assets_in(words):
            return command
        return other

    def _corrected(self, text: str) -> str:
        """What the request asks after its last correction where that asks for a command of its own
        ("make 3 copies? no - just augment ...": the words before "no -" are taken back, as the word
        accounting takes them); a correction of a value ("... actually just the paper variants")
        keeps the request whole."""
        lowered = text.lower()
        found = [
            m
            for p in self.vocab.corrections
            for m in phrase_pattern(p.lower()).finditer(lowered)
            if re.search(r"(?:^|[?.!;:,]|\s-)\s*$", lowered[: m.start()])  # one that starts a clause, not "instead of"
        ]
        tail = text[max(m.end() for m in found) :] if found else text
        _, score = self.intents.best(tail)
        return tail if score >= WEIGHTS["verbs"] else text  # "... actually just the paper variants" corrects a value

    def _expand(self, recipe: RecipeSpec, text: str, before: int, problems: list[str]) -> list[StepSpec]:
        """The recipe's steps, each filled from the clause's words (the recipe's own values win;
        its ``{from_step: N}`` count from the recipe's first step)."""
        steps: list[StepSpec] = []
        filled: dict[str, Any] = {}
        for item in recipe.steps:
            info = self.catalog.get(item.command)
            bound = {float(v) for k, v in filled.items() if isinstance(v, int | float) and not isinstance(v, bool)}
            args = self.arguments.fill(info, text, problems, bound)
            for key, value in recipe.defaults.items():
                name = "policy_type" if key == "policy" and "policy_type" in info.params else key
                if name in info.params and is_empty(args.get(name)) and not info.params[name].path:
                    args[name] = filled.get(key, value)
            filled.update({k: v for k, v in args.items() if not is_empty(v)})
            for key, value in item.args.items():
                args[key] = _recipe_value(value, before)
            steps.append(StepSpec(command=item.command, args=args))
        return steps

    def _each_product(
        self, info: CommandInfo, text: str, args: dict[str, Any], steps: list[StepSpec]
    ) -> list[dict[str, Any]]:
        """For a clause saying "both" or "each of them" about earlier outputs ("convert both"),
        the input of one step per earlier output of the kind the command reads."""
        if not find_phrase(self.vocab.each, words_of(text)):
            return []
        for name, kind in self.vocab.consumed(info.name).items():
            if not is_empty(args.get(name)):
                continue
            made = [
                i
                for i, step in enumerate(steps, 1)
                if step.command in self.vocab.products and self.vocab.products[step.command].kind == kind
            ]
            if len(made) > 1:
                many = info.params[name].multiple
                if many and find_phrase(self.vocab.together, words_of(text)):  # "convert both into one dataset"
                    return [{name: [{"from_step": i} for i in made]}]
                return [{name: [{"from_step": i}] if many else {"from_step": i}} for i in made]
        # "convert both raw and augmented, then train ACT on each": what the last steps of one command tell
        # apart (their dataset version), when this command reads none of their outputs
        group = list(itertools.takewhile(lambda s: s.command == steps[-1].command, reversed(steps))) if steps else []
        apart = [
            n
            for n in info.params
            if is_empty(args.get(n))
            and all(isinstance(s.args.get(n), str) for s in group)
            and len({s.args[n] for s in group}) == len(group) > 1
        ]
        return [{apart[0]: s.args[apart[0]]} for s in reversed(group)] if len(apart) == 1 else []

    def _done_before(self, text: str) -> bool:
        """A clause of only a word of the vocabulary's ``done_before`` and a cue ("after training",
        "once collected") says what happened before the next step: it plans nothing."""
        words = words_of(text).split()
        return len(words) == 2 and words[0] in self.vocab.done_before

    def _continues(self, info: CommandInfo, clause: Clause, args: dict[str, Any], steps: list[StepSpec]) -> bool:
        """A clause after "," / "and" / a sentence end that asks for the command of the step before
        and only gives values that step left open ("what does X look like? save the picture to
        y.png") completes that step."""
        if not steps or clause.after == "strong" or steps[-1].command != info.name or not args:
            return False
        if set(words_of(clause.text).split()) & set(self.vocab.repeats):  # "render it again at 256 px": another
            return False
        task = info.task_param()
        before = steps[-1].args
        if task is not None and task.name in args and args[task.name] != before.get(task.name):
            return False
        return not {k for k, v in args.items() if not is_empty(v)} & {
            k for k, v in before.items() if not is_empty(v)
        } - ({task.name} if task is not None else set())

    def _policy_only(self, text: str) -> str | None:
        """A clause naming a policy and no command asks to train it ("use VQ-BeT on the tube task")."""
        return "train" if "train" in self.catalog and self.arguments.policy(words_of(text)) else None
