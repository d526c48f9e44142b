"""The offline agent: a deterministic parser from a request to a command of the CLI.

Paths and addresses are taken out first (:mod:`.mentions`) and fill the command's path options;
the remaining words give the intent (verbs and nouns) and the parameters (task ids matched
against the registry or "all tasks", policy, dataset version, steps, episodes, seeds, sizes).
Defaults come from the registry and from the command's own defaults, and what is still missing
(a required value, or a required choice such as eval's endpoint or policy) is listed. It knows
only commands the CLI defines (see :mod:`.catalog`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

from pipette_cli.agent.catalog import AgentError, CommandCatalog, CommandInfo
from pipette_cli.agent.mentions import SAVE, assign_paths, find_mentions
from pipette_cli.agent.plan import CommandPlanSpec
from pipette_cli.errors import suggest
from pipette_cli.registry import Registry

# intent -> (command, words that signal it); the first intent whose words appear wins
INTENTS: list[tuple[str, str, tuple[str, ...]]] = [
    ("new-task", "new-task", ("create a task", "new task", "make a task", "add a task", "register a task", "author a task")),
    ("asset-new", "assets new", ("new asset", "make an asset", "create an asset", "generate an asset", "model a", "make a 3d")),
    ("delete", "data delete-episode", ("delete episode", "remove episode", "drop episode")),
    ("replay", "data replay", ("replay", "re-run episode", "verify episode", "check episode")),
    ("stats", "data stats", ("dataset stats", "statistics", "stats")),
    ("inspect", "data inspect", ("inspect", "what's in", "what is in", "look inside", "summarize the file", "summarise the file")),
    ("train", "train", ("train", "fine-tune", "finetune")),
    ("serve", "serve", ("serve", "policy server", "start a server", "host the policy")),
    ("report", "eval report", ("report", "results table", "summary table")),
    ("eval", "eval", ("evaluate", "evaluation", "eval ", "test the policy", "roll out the policy", "success rate of the policy")),
    ("augment", "augment", ("augment", "augmentation", "perturb")),
    ("convert", "convert", ("convert", "lerobot dataset", "to lerobot")),
    ("experts", "experts check", ("expert", "scripted success", "success rate of the script")),
    ("collect", "collect", ("collect", "record", "demonstration", "demos", "teleop", "gather")),
    ("step-rate", "sim step-rate", ("step rate", "step-rate", "how fast", "real-time factor", "realtime factor", "fps")),
    ("view", "sim view", ("viewer", "interactive", "open the scene", "view the")),
    ("render", "sim render", ("render", "picture", "image of", "screenshot", "views of", "look like")),
    ("validate-assets", "assets validate", ("validate the assets", "validate assets", "check the assets", "check assets")),
    ("assets", "assets list", ("list assets", "list the assets", "which assets", "what assets", "show assets", "asset library")),
    ("asset-show", "assets show", ("show asset", "describe asset", "details of asset", "asset details")),
    ("validate", "tasks validate", ("validate", "check the yaml", "lint")),
    ("list-all", "tasks list", ("all tasks", "which tasks", "what tasks", "available tasks", "list the tasks", "list tasks")),
    ("show", "tasks show", ("show", "describe", "details", "what is the task", "explain")),
    ("list", "tasks list", ("list", "which tasks", "what tasks", "all tasks", "available tasks")),
]

POLICIES = {"act": "act", "smolvla": "smolvla", "smol vla": "smolvla", "smol-vla": "smolvla", "pi0": "pi0", "pi 0": "pi0", "π0": "pi0", "pi-0": "pi0"}
TASK_SYNONYMS = {
    "tube": ("tube", "testtube", "falcon"), "test": ("test",), "centrifuge": ("centrifuge",), "lid": ("lid", "cover", "hatch"),
    "balance": ("balance", "scale"), "pipette": ("pipette", "pipettor"), "petri": ("petri", "dish", "plate"),
    "incubator": ("incubator",), "water": ("water",), "bath": ("bath",), "spectrophotometer": ("spectrophotometer", "spectro", "photometer"),
    "flask": ("flask", "erlenmeyer"), "shaker": ("shaker",), "rack": ("rack", "stand"), "button": ("button",),
    "pick": ("pick", "grab", "lift"), "place": ("place", "put"), "remove": ("remove", "take", "retriev"),
    "open": ("open",), "close": ("close", "shut"), "press": ("press", "push"), "thermal": ("thermal", "pcr"), "cycler": ("cycler",),
    "microcentrifuge": ("microcentrifuge",), "conical": ("conical",),
}
VERBS = {"pick", "place", "remove", "open", "close", "press"}
"""Concepts that are actions: they weigh half an object noun when matching a task."""


def _concepts(words: set[str]) -> set[str]:
    """Concepts named by ``words``; synonyms of 4+ letters also match as word stems ("closing")."""
    found = set()
    for concept, syns in TASK_SYNONYMS.items():
        for syn in syns:
            if syn in words or (len(syn) >= 4 and any(w.startswith(syn) or (len(w) >= 5 and syn.startswith(w[:-3]) and w.endswith("ing") and len(w[:-3]) >= 3) for w in words)):
                found.add(concept)
                break
    return found
NUMBER_WORDS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "eight": 8, "ten": 10, "twenty": 20,
                "thirty": 30, "fifty": 50, "hundred": 100, "a hundred": 100}


@dataclass
class Context:
    """What an interactive session remembers between requests ("now evaluate it ...")."""

    task: str | None = None
    file: str | None = None
    dataset: str | None = None
    policy_path: str | None = None
    history: list[CommandPlanSpec] = field(default_factory=list)


def _words(text: str) -> list[str]:
    return re.findall(r"[a-z0-9π]+", text.lower())


def _camel_words(name: str) -> list[str]:
    return [w.lower() for w in re.findall(r"[A-Z][a-z0-9]*|[0-9]+", name)]


def _number(text: str, *nouns: str) -> int | None:
    """An integer just before one of ``nouns`` ("50 episodes", "5k steps", "fifty demos")."""
    noun = "|".join(nouns)
    m = re.search(rf"(\d+(?:[.,]\d+)?)\s*(k|thousand)?\s*(?:{noun})", text)
    if m:
        value = float(m.group(1).replace(",", ""))
        return int(value * 1000) if m.group(2) else int(value)
    for word, value in sorted(NUMBER_WORDS.items(), key=lambda kv: -len(kv[0])):
        if re.search(rf"\b{word}\s+(?:{noun})", text):
            return value
    return None


def match_task(text: str, registry: Registry) -> tuple[str | None, list[str]]:
    """The registered task a request names: (id, []) or (None, closest candidates)."""
    lowered = text.lower()
    for tid in registry.ids():  # an explicit id or name wins
        short = tid.split("/", 1)[1]
        if tid.lower() in lowered or short.lower() in lowered or short.rsplit("-v", 1)[0].lower() in lowered.replace(" ", ""):
            return tid, []
    names = [t.split("/", 1)[1].rsplit("-v", 1)[0] for t in registry.ids()]
    for token in re.findall(r"\b(?:[a-z]+/)?[A-Z][a-z0-9]+(?:[A-Z][a-z0-9]*)+(?:-v\d+)?\b", text):
        raise AgentError(f"unknown task {token!r}; {suggest(token.split('/')[-1].rsplit('-v', 1)[0], names)}")
    concepts = _concepts(set(_words(text)))
    if not concepts:
        return None, []
    scores: dict[str, float] = {}
    for tid in registry.ids():
        spec = registry.get(tid)
        words = set(_camel_words(tid.split("/", 1)[1].rsplit("-v", 1)[0])) | {t.replace("-", "") for t in spec.tags}
        task_concepts = _concepts(words)
        shared = concepts & task_concepts
        if shared:
            weight = sum(0.5 if c in VERBS else 1.0 for c in shared)
            scores[tid] = weight + (0.25 if tid.startswith("pipette/") else 0.0)  # benchmark tasks first
    if not scores:
        return None, []
    best = max(scores.values())
    top = sorted(t for t, s in scores.items() if s >= best - 1e-9)
    if len(top) == 1:
        return top[0], []
    return None, top


ALL_TASKS = re.compile(
    r"\b(?:all|every|each)\b(?:\s+(?:of|the|\d+|registered|benchmark|paper|pipette|available|known))*\s+tasks?\b")
"""'all tasks', 'every task', 'all benchmark tasks', 'all 12 tasks'."""
NOT_TASK_WORDS = {
    "the", "a", "an", "it", "my", "our", "this", "that", "same", "policy", "policies", "model", "checkpoint", "raw",
    "augmented", "original", "unaugmented", "data", "dataset", "datasets", "demos", "demonstrations", "episodes",
    "gpu", "cpu", "cuda", *POLICIES,
}
"""Words a request uses around a task that never name one ("train act on the augmented data")."""


def _category(words: str) -> str | None:
    """The asset category a request names ("the instruments", "consumable assets")."""
    from pipette_cli.assets.library import CATEGORIES

    return next((c for c in CATEGORIES if re.search(rf"\b{c.removesuffix('s')}s?\b", words)), None)


class OfflineAgent:
    """Deterministic request parser over the CLI catalog and the task registry."""

    name = "offline"

    def __init__(self, catalog: CommandCatalog, registry: Registry) -> None:
        self.catalog = catalog
        self.registry = registry

    def intent(self, text: str) -> tuple[str, str]:
        """(intent, command) from the words of ``text``; paths and addresses do not count."""
        lowered = f" {find_mentions(text, self.registry.ids()).words.lower()} "
        for intent, command, cues in INTENTS:
            if any(re.search(rf"(?<![a-z]){re.escape(cue.strip())}", lowered) for cue in cues):
                return intent, command
        if _category(lowered):  # "which tools are there"
            return "assets", "assets list"
        raise AgentError(
            "cannot tell what to run from this request; say e.g. 'list the tasks', 'collect 20 demos of "
            "PickUpTestTube', 'inspect data/x.h5'"
        )

    def _task(self, words: str, info: CommandInfo, param: str, context: Context, notes: list[str]) -> str | None:
        """The task value for ``param`` of ``info``: a registered id, ``all``, or None (missing).

        Raises:
            AgentError: an unknown or ambiguous task, or "all tasks" for a command that runs one.
        """
        lowered = words.lower()
        option = info.params[param]
        if ALL_TASKS.search(lowered):
            if "`all`" in option.help:
                return "all"
            if option.required:
                raise AgentError(f"'pipette {info.name}' runs one task at a time; name the task")
            return None  # the command's default covers every task
        task, candidates = match_task(words, self.registry)
        if task is None and re.search(r"\b(it|that task|the same task|this task)\b", lowered) and context.task:
            notes.append(f"task from context: {context.task}")
            return context.task
        if candidates:
            raise AgentError(f"the request could mean several tasks: {', '.join(candidates)}; name one")
        if task is None and option.required:
            named = re.search(
                r"(?:task|on|of|for)\s+(?:the\s+)?([A-Za-z][\w-]+(?:\s+[a-z]+){0,3}?)(?:\s+task|$|\s+with|\s+for)", words)
            if named and set(named.group(1).lower().split()) - NOT_TASK_WORDS:
                names = [t.split("/", 1)[1].rsplit("-v", 1)[0] for t in self.registry.ids()]
                raise AgentError(f"unknown task {named.group(1)!r}; {suggest(named.group(1).replace(' ', ''), names)}")
        return task

    def plan(self, text: str, context: Context | None = None) -> CommandPlanSpec:
        """The command for ``text``; required values the request lacks are listed in ``missing``."""
        context = context or Context()
        mentions = find_mentions(text, self.registry.ids())
        words = mentions.words  # what is read as words: paths and addresses are values, not words
        lowered = words.lower()
        intent, command = self.intent(words)
        if command not in self.catalog:
            available = ", ".join(sorted({c.split()[0] for c in self.catalog.commands}))
            raise AgentError(f"'pipette {command}' is not available in this version (commands: {available})")
        category = _category(lowered)
        if command in ("tasks list", "tasks show") and (
            "asset" in lowered or (category and not re.search(r"\btasks?\b", lowered))
        ):
            # "list the instruments", "show the consumables": a category, no single asset -> the list
            command = "assets show" if command == "tasks show" and self._asset_id(lowered) else "assets list"
        params: dict[str, Any] = {}
        notes: list[str] = []
        info = self.catalog.get(command)

        def want(name: str) -> bool:
            return name in info.params

        # new-task's --id names the task to create: never filled from the registry
        task_param = None if command == "new-task" else next((p for p in ("task_id", "tasks", "task") if want(p)), None)
        if task_param:
            task = self._task(words, info, task_param, context, notes)
            if task is not None:
                params[task_param] = [task] if info.params[task_param].multiple else task
                if task != "all":
                    context.task = task
        for address in mentions.addresses:
            key = next((k for k in ("endpoint", "bind") if want(k)), None)
            if key is None:
                raise AgentError(f"'pipette {command}' takes no address like {address!r}")
            params[key] = address
        paths = mentions.paths
        if want("description"):  # free text: only "save it to PATH" is a path, the rest describes
            paths = [m for m in paths if SAVE.search(m.before)]
        assign_paths(info, paths, params)
        file_param = next((p for p in ("file", "input", "inputs") if want(p) and info.params[p].required), None)
        if file_param and not params.get(file_param) and context.file:
            params[file_param] = [context.file] if info.params[file_param].multiple else context.file
            notes.append(f"file from context: {context.file}")
        if want("episodes"):
            n = _number(lowered, "episodes?", "demos?", "demonstrations?", "rollouts?", "trials?", "runs?", "seeds?")
            if n is not None:
                params["episodes"] = n
        if want("episode") and command != "data delete-episode":
            m = re.search(r"episode\s+#?(\d+)", lowered)
            if m:
                params["episode"] = int(m.group(1))
        if command == "data delete-episode":
            m = re.search(r"episode\s+#?(\d+)", lowered)
            params["index"] = int(m.group(1)) if m else None
        if command == "data replay":
            params["check"] = True
        for key, pattern in (("seed", r"seed\s*(?:=|of|:)?\s*(\d+)"), ("image_size", r"(\d+)\s*(?:px|pixels?)\b|(\d+)\s*x\s*\2"),
                             ("workers", r"(\d+)\s*(?:workers?|processes|cores)"), ("steps", r"(\d+(?:[.,]\d+)?)\s*(k)?\s*(?:training\s+)?steps?")):
            if want(key):
                m = re.search(pattern, lowered)
                if m:
                    value = next(g for g in m.groups() if g and g[0].isdigit())
                    number = float(value.replace(",", ""))
                    if key == "steps" and len(m.groups()) > 1 and m.group(2):
                        number *= 1000
                    params[key] = int(number)
        if want("source"):
            if re.search(r"\b(teleop|keyboard|by hand|manually|myself)\b", lowered):
                params["source"] = "teleop"
        # a policy *name* (act, smolvla, pi0) goes to the option that takes one: train's --policy,
        # eval's --policy-type; eval's and serve's --policy take a folder
        policy_key = next((k for k in ("policy", "policy_type") if want(k) and not info.params[k].path), None)
        if policy_key:
            for word, policy in POLICIES.items():
                if re.search(rf"(?<![a-z]){re.escape(word)}(?![a-z])", lowered):
                    params[policy_key] = policy
                    break
        if want("dataset_version"):
            if "augment" in lowered:
                params["dataset_version"] = "augmented"
            elif re.search(r"\braw\b|original|unaugmented|un-augmented", lowered):
                params["dataset_version"] = "raw"
        if want("device"):
            if re.search(r"\b(gpu|cuda)\b", lowered):
                params["device"] = "cuda"
            elif re.search(r"\bcpu\b", lowered):
                params["device"] = "cpu"
        if want("as_json") and re.search(r"\bjson\b", lowered):
            params["as_json"] = True
        if want("tag") and command == "tasks list":
            for tag in ("hatch_control", "placement_relocation", "consumable_handling", "paper-benchmark", "generated",
                        "agilex_piper", "piper", "lid", "pick", "place", "press"):
                if tag.replace("_", " ") in lowered or tag in lowered:
                    params["tag"] = {"piper": "agilex_piper"}.get(tag, tag)
                    break
            if "lid" in lowered or "hatch" in lowered:
                params["tag"] = "hatch_control"
        if want("category") and category:
            params["category"] = category
        if want("description"):
            said = text
            for m in paths:  # "... and save it to x.yaml" is not part of the description
                said = re.sub(rf"[,;]?\s*(?:and\s+)?\b(?:save|write|store)s?\b[^,;]*?{re.escape(m.path)}\S*", "", said)
            quoted = re.search(r"[\"“'](.+?)[\"”']", said)
            rest = re.sub(r"^.*?\b(?:where|in which|that|:|for|to)\s+", "", said, count=1)
            params["description"] = quoted.group(1) if quoted else rest.strip()
        if want("asset_id") and command == "assets show" and not params.get("asset_id"):
            params["asset_id"] = self._asset_id(lowered)
        if command == "collect" and not params.get("out") and params.get("task_id"):
            short = str(params["task_id"]).split("/", 1)[1].rsplit("-v", 1)[0]
            params["out"] = f"data/{short}.h5"
            notes.append(f"default output data/{short}.h5")
        if command == "collect" and params.get("out"):
            context.file = str(params["out"])
        missing = self.catalog.missing(command, params)
        return CommandPlanSpec(command=command, params={k: v for k, v in params.items() if v is not None},
                               missing=missing, notes=notes)

    @staticmethod
    def _asset_id(lowered: str) -> str | None:
        from pipette_cli.assets.library import load_asset_library

        return next((a for a in load_asset_library().ids() if a in lowered.replace(" ", "_")), None)
