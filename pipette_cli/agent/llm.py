"""The agent through an LLM server: the model fills the same :class:`PlanSpec` as the offline
parser, through structured output, and the same validator checks it.

The model sees a compact catalog (all commands by name; the parameters, with types and
choices, of the commands the request's words point to) and the task ids, and must answer a
JSON plan whose ``command`` is one of the catalog's names. An answer the validator rejects
(unknown command, parameter, task or value; a bad step reference) is sent back with the error,
up to the server's attempt limit (:func:`pipette_cli.llm.ask_structured`); an unsupported
policy ends it at once. Nothing the model says is executed as code, and only a plan that
passed the validator is ever shown as runnable.
"""

from __future__ import annotations

import copy
import json
from typing import Any

from pipette_cli.agent.catalog import CommandCatalog, CommandInfo
from pipette_cli.agent.clauses import Intents
from pipette_cli.agent.plan import CheckedPlan, Context, PlanSpec
from pipette_cli.agent.validate import Validator
from pipette_cli.agent.vocabulary import VocabularySpec, load_vocabulary
from pipette_cli.llm import ChatClient, ask_structured, make_client, strict_json_schema
from pipette_cli.registry import Registry

EXAMPLE = {"steps": [
    {"command": "collect", "args": {"task_id": "pipette/PickUpTestTube-v1", "episodes": 5}},
    {"command": "augment", "args": {"task_id": "pipette/PickUpTestTube-v1", "input": {"from_step": 1}}},
]}


def _param_text(info: CommandInfo) -> str:
    parts = []
    for p in info.params.values():
        kind = "|".join(p.values()) if p.values() and p.kind == "str" else p.kind
        parts.append(f"{p.name}{'*' if p.required else ''}:{kind}")
    return ", ".join(parts)


def plan_prompt(catalog: CommandCatalog, registry: Registry, relevant: set[str]) -> str:
    """Instructions for the model: the plan format, the catalog and the task ids (compact)."""
    lines = [
        "You turn a user's request about the `pipette` robot-learning CLI into a plan: one step per command, in order.",
        'Answer with JSON only: {"steps": [{"command": "<name>", "args": {"<parameter>": <value>}}]}.',
        'A step can use an earlier step\'s output file or folder as a value: {"from_step": <step number>}.',
        "Use only the commands and parameters below (* = required) and the task ids listed; leave out values",
        "the request does not give. Questions about tasks, demo counts or evaluation scores use the answer commands.",
        "Commands:",
    ]
    for name, info in catalog.commands.items():
        detail = f" [{_param_text(info)}]" if name in relevant else ""
        lines.append(f"- {name}: {info.help}{detail}")
    lines.append("Task ids: " + ", ".join(f"{tid} ({registry.get(tid).instruction.rstrip('.')})"
                                            for tid in registry.ids()))
    lines.append('Example: "record 5 demos of the test tube task and augment them" -> '
                 + json.dumps(EXAMPLE, separators=(",", ":")))
    return "\n".join(lines)


def plan_schema(catalog: CommandCatalog) -> dict[str, Any]:
    """:class:`PlanSpec`'s JSON schema with ``command`` narrowed to the catalog's names."""
    schema = copy.deepcopy(strict_json_schema(PlanSpec))
    step = schema["$defs"]["StepSpec"]
    step["properties"]["command"]["enum"] = sorted(catalog.commands)
    return schema


class LLMAgent:
    """Requests -> checked plans through an OpenAI-compatible or Ollama server."""

    def __init__(self, kind: str, catalog: CommandCatalog, registry: Registry, vocab: VocabularySpec | None = None,
                 client: ChatClient | None = None, **options: Any) -> None:
        self.name = kind
        self.catalog = catalog
        self.registry = registry
        self.vocab = vocab or load_vocabulary()
        self.client = client or make_client(kind, **options)
        self.validator = Validator(catalog, registry, self.vocab)
        self.intents = Intents(self.vocab, set(catalog.commands), registry.ids())
        self.trace: list[str] = []
        """What happened on each attempt of the last request."""

    def relevant(self, text: str) -> set[str]:
        """Commands the request's words point to (their parameters go into the prompt)."""
        scores = self.intents.scores(text)
        return {c for c, s in scores.items() if s >= max(scores.values(), default=0) - 1} or {"collect", "train", "eval"}

    def plan(self, text: str, context: Context | None = None) -> CheckedPlan:
        """The checked plan for ``text``.

        Raises:
            BackendError: no valid plan within the attempts (each attempt's problem listed).
            Unsupported: the request asks for something Pipette does not do.
        """
        def accept(spec: PlanSpec) -> CheckedPlan:
            return self.validator.check(spec, request=text, context=context)

        self.trace = []
        return ask_structured(self.client, system=plan_prompt(self.catalog, self.registry, self.relevant(text)),
                              user=text, schema=PlanSpec, accept=accept, json_schema=plan_schema(self.catalog),
                              fix_hint="Fix the plan (only commands, parameters and task ids from the lists)",
                              trace=self.trace)
