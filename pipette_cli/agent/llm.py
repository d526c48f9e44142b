"""The agent through an LLM backend: structured output validated against the CLI's schema.

The model sees the command catalog and must answer a :class:`CommandPlanSpec`; the answer is
accepted only if it names a command of the catalog and parameters of that command, otherwise
the backend re-asks with the errors (bounded attempts). Nothing it says is executed as code.
"""

from __future__ import annotations

from pipette_cli.agent.catalog import ONE_OF, AgentError, CommandCatalog
from pipette_cli.agent.plan import CommandPlanSpec
from pipette_cli.authoring.backends import make_backend
from pipette_cli.registry import Registry


def catalog_prompt(catalog: CommandCatalog, registry: Registry) -> str:
    lines = [
        "You turn a user's request into exactly one command of the `pipette` CLI.",
        "Answer with JSON: command (one of the names below), params (parameter name -> value),",
        "missing (required parameters the request does not give). Use only these commands:",
    ]
    for name, info in sorted(catalog.commands.items()):
        params = ", ".join(f"{p.name}{'*' if p.required else ''}" for p in info.params.values())
        choice = f" (needs one of {', '.join(ONE_OF[name])})" if name in ONE_OF else ""
        lines.append(f"- {name}: {info.help} [{params}]{choice}")
    lines.append("Task ids: " + ", ".join(registry.ids()))
    return "\n".join(lines)


class LLMAgent:
    """Requests -> commands through an OpenAI-compatible or Ollama backend."""

    def __init__(self, backend: str, catalog: CommandCatalog, registry: Registry, **options: object) -> None:
        self.name = backend
        self.backend = make_backend(backend, **options)
        self.catalog = catalog
        self.registry = registry

    def _accept(self, plan: CommandPlanSpec) -> CommandPlanSpec:
        info = self.catalog.get(plan.command)  # AgentError (a PipetteError) -> the backend re-asks
        unknown = [k for k in plan.params if k not in info.params]
        if unknown:
            raise AgentError(f"'pipette {plan.command}' has no parameter(s) {', '.join(unknown)}")
        for key in ("task_id", "tasks"):
            value = plan.params.get(key)
            for task in value if isinstance(value, list) else str(value).split(",") if value else []:
                task = str(task).strip()
                if task == "all" and "`all`" in info.params[key].help:
                    continue  # train --tasks all
                self.registry.get(task)  # TaskNotFound with suggestions -> re-asked
        missing = self.catalog.missing(plan.command, plan.params)
        return plan.model_copy(update={"missing": missing})

    def plan(self, text: str, context: object | None = None) -> CommandPlanSpec:
        return self.backend.complete(
            system=catalog_prompt(self.catalog, self.registry), user=text, schema=CommandPlanSpec, accept=self._accept
        )
