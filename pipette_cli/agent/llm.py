"""The agent through an LLM server: the model fills the same :class:`PlanSpec` as the offline
parser, through structured output, and the same validator checks it.

The model sees a compact catalog (the commands the request's words point to with their
parameters, types and choices; the others by name) and the task ids, and must answer a
JSON plan whose ``command`` is one of the catalog's names. An answer the validator rejects
(unknown command, parameter, task or value; a bad step reference) is sent back with the error,
up to the server's attempt limit (:func:`pipette_cli.llm.ask_structured`); an unsupported
policy ends it at once. Nothing the model says is executed as code, and only a plan that
passed the validator is ever shown as runnable.
"""

from __future__ import annotations

import copy
from typing import Any

from pipette_cli.agent.catalog import CommandCatalog, CommandInfo, ParamInfo
from pipette_cli.agent.clauses import Intents
from pipette_cli.agent.plan import CheckedPlan, Context, PlanSpec
from pipette_cli.agent.validate import Validator
from pipette_cli.agent.vocabulary import WorkflowVocabularySpec, lexicon
from pipette_cli.llm import ChatClient, ask_structured, make_client, strict_json_schema
from pipette_cli.registry import Registry


def _param_text(info: CommandInfo) -> str:
    parts = []
    for p in info.params.values():
        kind = "|".join(p.values()) if p.values() and p.kind == "str" else p.kind
        parts.append(f"{p.name}{'*' if p.required else ''}:{kind}")
    return ", ".join(parts)


def plan_prompt(catalog: CommandCatalog, registry: Registry, relevant: set[str]) -> str:
    """Instructions for the model: the plan format, the commands the request points to with
    their parameters, the other commands by name, and the task ids (about 500 tokens)."""
    lines = [
        "Turn the user's request about the `pipette` robot-learning CLI into a plan: one step per command, in order.",
        'Answer with one JSON object: "steps" is a list of steps; each step has "command" (a command name) and',
        '"args" (parameter name -> value). A value can be an earlier step\'s output file or folder: {"from_step": N}.',
        "Use only these commands and parameters (* = required) and these task ids; leave out what the request",
        "does not say. Questions about tasks, demo counts or evaluation scores use the `answer` commands.",
    ]
    for name in sorted(relevant):
        info = catalog.get(name)
        lines.append(f"- {name}: {info.help} [{_param_text(info)}]")
    lines.append("Other commands: " + ", ".join(sorted(set(catalog.commands) - relevant)))
    lines.append("Task ids: " + ", ".join(registry.ids()))
    return "\n".join(lines)


def _value_schema(param: ParamInfo, task_ids: list[str]) -> dict[str, Any]:
    kinds = {"int": "integer", "float": "number", "bool": "boolean"}
    if param.kind == "task":
        schema: dict[str, Any] = {"type": "string", "enum": [*task_ids, *(["all"] if "`all`" in param.help else [])]}
    elif param.choices:
        schema = {"type": "string", "enum": list(param.choices)}
    else:
        schema = {"type": kinds.get(param.kind, "string")}
    if param.path or param.address:
        schema = {"anyOf": [schema, {"$ref": "#/$defs/StepRef"}]}
    return {"type": "array", "items": schema} if param.multiple else schema


def plan_schema(catalog: CommandCatalog, relevant: set[str], task_ids: list[str]) -> dict[str, Any]:
    """The JSON schema sent to the server: :class:`PlanSpec`, with one step shape per command
    the request points to (its parameters by name, typed, task ids and choices as enums), so a
    server that constrains decoding cannot produce an unknown parameter; other commands take
    any arguments (the validator checks them)."""
    generic = strict_json_schema(PlanSpec)
    shapes = []
    for name in sorted(relevant):
        params = catalog.get(name).params
        shapes.append(
            {
                "type": "object",
                "additionalProperties": False,
                "required": ["command", "args"],
                "properties": {
                    "command": {"type": "string", "enum": [name]},
                    "args": {
                        "type": "object",
                        "additionalProperties": False,
                        "properties": {p: _value_schema(info, task_ids) for p, info in params.items()},
                    },
                },
            }
        )
    other = copy.deepcopy(generic["$defs"]["StepSpec"])
    other["properties"]["command"]["enum"] = sorted(set(catalog.commands) - relevant)
    shapes.append(other)
    return {
        "type": "object",
        "additionalProperties": False,
        "required": ["steps"],
        "properties": {"steps": {"type": "array", "minItems": 1, "maxItems": 12, "items": {"anyOf": shapes}}},
        "$defs": {"StepRef": generic["$defs"]["StepRef"]},
    }


class LLMAgent:
    """Requests -> checked plans through an OpenAI-compatible or Ollama server."""

    def __init__(
        self,
        kind: str,
        catalog: CommandCatalog,
        registry: Registry,
        vocab: WorkflowVocabularySpec | None = None,
        client: ChatClient | None = None,
        **options: Any,
    ) -> None:
        self.name = kind
        self.catalog = catalog
        self.registry = registry
        self.vocab = vocab or lexicon(registry)
        self.client = client or make_client(kind, **options)
        self.validator = Validator(catalog, registry, self.vocab)
        self.intents = Intents(self.vocab, catalog, registry.ids())
        self.trace: list[str] = []
        """What happened on each attempt of the last request."""

    def relevant(self, text: str) -> set[str]:
        """Commands the request's words point to (their parameters go into the prompt)."""
        scores = self.intents.scores(text)
        return {c for c, s in scores.items() if s >= max(scores.values(), default=0) - 1} or {
            "collect",
            "train",
            "eval",
        }

    def plan(self, text: str, context: Context | None = None) -> CheckedPlan:
        """The checked plan for ``text``.

        Raises:
            BackendError: no valid plan within the attempts (each attempt's problem listed).
            Unsupported: the request asks for something Pipette does not do.
        """

        def accept(spec: PlanSpec) -> CheckedPlan:
            return self.validator.check(spec, request=text, context=context)

        self.trace = []
        relevant = self.relevant(text)
        return ask_structured(
            self.client,
            system=plan_prompt(self.catalog, self.registry, relevant),
            user=text,
            schema=PlanSpec,
            accept=accept,
            json_schema=plan_schema(self.catalog, relevant, self.registry.ids()),
            fix_hint="Fix the plan (only commands, parameters and task ids from the lists)",
            trace=self.trace,
        )
