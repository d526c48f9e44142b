"""The words of a drafted task: its id, its name, and each stage's instruction.

An id is ``namespace/Name-v1``; the name says the steps in CamelCase, as short as needed to stay
readable and within :data:`MAX_ID` characters under the default namespace: first every asset in
full (``PlaceConicalTube15mlOnElectronicBalance``), then by kind (``PlaceConicalTubeOnBalance``),
then leaving out what the previous step named ("it"), then the head nouns, and last the verbs
followed by the objects (``OpenPlaceCloseRunMicrocentrifuge``). A stage's instruction says its step
in words ("Place the 1.5 mL microtube in the microcentrifuge.").
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterator

from pipette_cli.taskgen.plan import PlanStepSpec
from pipette_cli.taskgen.validate import CheckedPlan

MAX_ID = 48
"""Characters of a generated id under the default namespace (``generated/...-v1``)."""
MAX_NAME = MAX_ID - len("generated/") - len("-v1")
HATCHES = ("lid", "door", "drawer", "sash")
ORDINALS = ("first", "second", "third", "fourth", "fifth", "sixth", "seventh", "eighth", "ninth", "tenth")
"""How objects of one asset are told apart in a stage's instruction, in the plan's order."""
INTO_SITES = ("slot_", "well", "opening", "inside_bottom", "cuvette_slot", "rotor_center", "shelf_")
"""Sites of a holder that things go *in* (a rack, a rotor, a box, a shelf); other holders are surfaces."""
RELATION_WORDS = {
    "next_to": ("NextTo", "next to"),
    "left_of": ("LeftOf", "to the left of"),
    "right_of": ("RightOf", "to the right of"),
    "behind": ("Behind", "behind"),
    "in_front_of": ("InFrontOf", "in front of"),
}


def camel(text: str) -> str:
    """``ConicalTube15ml`` for ``conical_tube_15ml`` or ``conical tube 15ml`` (``1_5`` -> ``1p5``)."""
    text = re.sub(r"(\d)_(\d)", r"\1p\2", text)
    return "".join(part[:1].upper() + part[1:] for part in re.split(r"[_\s]+", text) if part)


def _into(checked: CheckedPlan, name: str) -> bool:
    sites = checked.objects[name].info.semantics.get("sites", [])
    return any(str(s).startswith(INTO_SITES) for s in sites)


def step_words(step: PlanStepSpec, names: dict[str, str], checked: CheckedPlan) -> list[tuple[str, str | None]]:
    """One step as ``(word, object)`` pieces in CamelCase; ``object`` marks the pieces that name one."""
    obj = step.object
    part = camel(step.part) if step.part in HATCHES else ""
    if step.action == "place" and step.relation:
        return [
            ("Place", None),
            (names[obj], obj),
            (RELATION_WORDS[step.relation][0], None),
            (names[step.required_target()], step.target),
        ]
    prep = "In" if step.target and _into(checked, step.target) else "On"
    table: dict[str, list[tuple[str, str | None]]] = {
        "pick": [("PickUp", None), (names[obj], obj)]
        + ([("From", None), (names[step.source], step.source)] if step.source else []),
        "place": [("Place", None), (names[obj], obj), (prep, None), (names[step.target or obj], step.target)],
        "remove": [("Remove", None), (names[obj], obj)]
        + ([("From", None), (names[step.source], step.source)] if step.source else []),
        "position": [("Position", None), (names[obj], obj), ("Over", None), (names[step.target or obj], step.target)],
        "open": [("Open", None), (names[obj], obj)] + ([(part, None)] if part else []),
        "close": [("Close", None), (names[obj], obj)] + ([(part, None)] if part else []),
        "press": [("Press", None), (names[obj], obj), ("Button", None)],
        "run": [("Run", None), (names[obj], obj)],
        "tare": [("Tare", None), (names[obj], obj)],
    }
    return table[step.action]


def _names(checked: CheckedPlan, level: int) -> dict[str, str]:
    """Each object's CamelCase name: 0 its asset, 1 its kind, 2 the kind's last word."""
    out = {}
    for name, o in checked.objects.items():
        kind = o.info.kinds[0] if o.info.kinds else o.asset.replace("_", " ")
        out[name] = camel(o.asset) if level == 0 else camel(kind) if level == 1 else camel(kind.split()[-1])
    return out


def _spelled(checked: CheckedPlan, level: int, joiner: str, elide: bool) -> str:
    names = _names(checked, level)
    parts: list[str] = []
    before: set[str] = set()
    for step in checked.steps:
        pieces = step_words(step, names, checked)
        named = {o for _, o in pieces if o}
        if elide:  # what the step before named is "it": left out, with the word that led to it
            kept: list[str] = []
            for k, (word, o) in enumerate(pieces):
                if o in before or (o is None and k + 1 < len(pieces) and pieces[k + 1][1] in before and k > 0):
                    continue
                kept.append(word)
            parts.append("".join(kept))
        else:
            parts.append("".join(word for word, _ in pieces))
        before = named
    return joiner.join(parts)


def _verbs_then_objects(checked: CheckedPlan) -> Iterator[str]:
    """``OpenPlaceCloseRunMicrocentrifugeTube``, with objects left off the end until it fits."""
    verbs = [step_words(s, _names(checked, 2), checked)[0][0] for s in checked.steps]
    verbs = [v for k, v in enumerate(verbs) if k == 0 or v != verbs[k - 1]]
    objects: list[str] = []
    for step in checked.steps:
        for name in (step.object, step.target, step.source):
            if name and name not in objects:
                objects.append(name)
    heads = _names(checked, 2)
    for n in range(len(objects), 0, -1):
        yield "".join(verbs) + "".join(dict.fromkeys(heads[o] for o in objects[:n]))


def task_name_options(checked: CheckedPlan) -> list[str]:
    """Names of the task, most explicit first (see the module docstring)."""
    options = [
        _spelled(checked, 0, "Then", False),
        _spelled(checked, 1, "Then", False),
        _spelled(checked, 1, "Then", True),
        _spelled(checked, 1, "", True),
        _spelled(checked, 2, "", True),
        *_verbs_then_objects(checked),
    ]
    return list(dict.fromkeys(options))


def task_id(checked: CheckedPlan, namespace: str) -> str:
    """The most explicit ``namespace/Name-v1`` whose name fits :data:`MAX_NAME` (an id already
    registered is reported by the caller, not dodged: the same description twice is one task)."""
    fitting = [n for n in task_name_options(checked) if len(n) <= MAX_NAME]
    if not fitting:  # whole CamelCase words of the shortest option, as many as fit
        name = ""
        for word in re.findall(r"[A-Z][a-z0-9]*", task_name_options(checked)[-1]):
            if len(name + word) > MAX_NAME:
                break
            name += word
        fitting = [name]
    return f"{namespace}/{fitting[0]}-v1"


def step_name(step: PlanStepSpec, checked: CheckedPlan) -> str:
    """``place the 15 mL conical tube on the balance`` for one step; objects of the same asset are told
    apart in the plan's order ("the second 2 mL microtube")."""
    n = {name: o.info.human_name() for name, o in checked.objects.items()}
    same = Counter(n.values())
    seen: Counter[str] = Counter()
    for name, human in list(n.items()):
        if same[human] > 1:
            seen[human] += 1
            k = seen[human]
            n[name] = f"{ORDINALS[k - 1] if k <= len(ORDINALS) else f'{k}th'} {human}"
    obj = n[step.object]
    part = step.part if step.part in HATCHES else ""
    if step.action == "place" and step.relation:
        return f"place the {obj} {RELATION_WORDS[step.relation][1]} the {n[step.required_target()]}"
    into = "in" if step.target and _into(checked, step.target) else "on"
    return {
        "pick": lambda: f"pick up the {obj}" + (f" from the {n[step.source]}" if step.source else ""),
        "place": lambda: f"place the {obj} {into} the {n[step.required_target()]}",
        "remove": lambda: f"remove the {obj}" + (f" from the {n[step.source]}" if step.source else ""),
        "position": lambda: f"position the {obj} over the {n[step.required_target()]}",
        "open": lambda: f"open the {obj} {part}".strip(),
        "close": lambda: f"close the {obj} {part}".strip(),
        "press": lambda: f"press the {obj} button",
        "run": lambda: f"start the {obj}",
        "tare": lambda: f"tare the {obj}",
    }[step.action]()


def stage_instruction(step: PlanStepSpec, checked: CheckedPlan) -> str:
    """The language instruction of one stage: its step as a sentence."""
    words = step_name(step, checked)
    return words[:1].upper() + words[1:] + "."
