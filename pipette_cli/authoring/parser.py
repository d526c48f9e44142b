"""The offline backend: an English description -> :class:`~pipette_cli.taskgen.plan.TaskPlanSpec`.

Deterministic: the text is normalised (:mod:`.text`), split into steps at sequence words, each
step read against the vocabulary (:mod:`.clause`), and the steps assembled into one plan. Objects
named again ("the tube", "it") are the same object; an object of the same kind named with other
sizes or "other" is a new one ("put the 50 mL beaker in the 250 mL beaker"); :mod:`.assembly`
merges and names them into the plan. What the simulator cannot do (liquids, screwing caps, running
instruments without a start button) and words that name nothing known are refused with the reason
(:mod:`.refusals`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from pipette_cli.authoring.assembly import Obj, RawStep, assemble
from pipette_cli.authoring.clause import Clause, ClauseReader, Mention, Part
from pipette_cli.authoring.refusals import ACTION_WORDS, refuse_unknown, refuse_unsupported
from pipette_cli.authoring.text import (
    CONDITIONS,
    extract_thresholds,
    has_negation,
    inverted_of,
    normalise,
    split_steps,
    subordinates,
)
from pipette_cli.language.assets import Vocabulary
from pipette_cli.language.lexicon import robot_mentions
from pipette_cli.language.phrases import Token
from pipette_cli.language.understanding import not_understood_line
from pipette_cli.taskgen.plan import (
    INSTRUMENT_ACTIONS,
    PlanError,
    TaskPlanSpec,
)
from pipette_cli.taskgen.resolve import Wanted

HATCH_PARTS = ("lid", "door", "drawer", "sash")
REMOVING = ("out of", "off", "off of", "out from", "from inside")
"""Source prepositions that make "take X ..." a removal rather than a lift."""
NEW_OBJECT = ("other", "another", "second", "new", "different")


@dataclass
class ParseResult:
    """The plan and the remarks that become VERIFY notes (choices among equal assets)."""

    plan: TaskPlanSpec
    remarks: list[str]
    not_understood: list[str] = field(default_factory=list)
    """Words of the description the plan does not use (shown with it; never written under --yes)."""


@dataclass
class Builder:
    """Assembles the steps of one description into a plan."""

    vocab: Vocabulary
    objects: list[Obj] = field(default_factory=list)
    steps: list[RawStep] = field(default_factory=list)
    remarks: list[str] = field(default_factory=list)
    introduced: list[Obj] = field(default_factory=list)
    """Objects a goal clause names before the steps ("I need a 50 mL falcon tube spun down: ...")."""

    def introduce(self, goal: Clause) -> None:
        """The objects ``goal`` names, for the steps to refer to ("..., load the tube")."""
        self.introduced += [self.obj(m, goal, "object", []) for m in goal.objects() if not m.is_pronoun]

    # ------------------------------------------------------------------ objects
    def _static(self, obj: Obj) -> bool:
        return all(
            self.vocab.assets[a].static or not self.vocab.assets[a].graspable
            for a in self.vocab.members(obj.wanted.kind)
        )

    def _moved(self) -> list[Obj]:
        return [
            s.object for s in self.steps if s.object is not None and s.action in ("pick", "place", "remove", "position")
        ]

    def _holders(self) -> list[Obj]:
        out = []
        for s in self.steps:
            out += [o for o in (s.target, s.source) if o is not None]
            if s.action in INSTRUMENT_ACTIONS and s.object is not None:
                out.append(s.object)
        return out

    def pronoun(self, role: str, clause: Clause) -> Obj:
        if role == "instrument":  # one a step worked on; else one named before in this sentence ("... with X on it")
            pool = [o for s in self.steps for o in (s.object, s.target, s.source) if o is not None and self._static(o)]
            pool = pool or [o for o in self.objects if self._static(o)]
        elif role == "holder":
            pool = self._holders() or [o for o in self.objects if self._static(o)]
        else:
            pool = self._moved() or [o for o in self.objects if not self._static(o)]
        if not pool:
            what = "instrument or holder" if role in ("instrument", "holder") else "object"
            raise PlanError(f"'{clause.text}': nothing named before says which {what} is meant; name the {what}")
        return pool[-1]

    def obj(self, mention: Mention, clause: Clause, role: str, taken: list[Obj]) -> Obj:
        """The plan object ``mention`` names: an earlier one of the same kind, or a new one."""
        if mention.is_pronoun and "other" in mention.phrase.split() and role == "item":
            # "the other one": not the one just named; another object named before, else a new one of its kind
            last = taken[-1] if taken else self.pronoun(role, clause)
            other = [
                o for o in self._moved() or self.objects if o is not last and not self._static(o) and o not in taken
            ]
            if other:
                return other[-1]
            self.objects.append(Obj(last.mention, last.wanted))
            return self.objects[-1]
        if mention.is_pronoun:
            return self.pronoun(role, clause)
        wanted = Wanted(mention.kind, tuple(mention.sizes), tuple(m for m in mention.modifiers if m not in NEW_OBJECT))
        fresh = any(m in NEW_OBJECT for m in mention.modifiers)
        if not fresh:
            mine = set(self.vocab.members(mention.kind))
            for old in reversed(self.objects):
                if old in taken or not mine & set(self.vocab.members(old.wanted.kind)):
                    continue
                if set(wanted.sizes) - set(old.wanted.sizes) or set(wanted.modifiers) - set(old.wanted.modifiers) - {
                    "open"
                }:
                    continue
                return old
        made = Obj(mention, wanted)
        self.objects.append(made)
        return made

    # ------------------------------------------------------------------ steps
    def add(self, clause: Clause) -> None:
        action = clause.action
        direct = [m for m in clause.mentions if not m.is_bench and (m.prep is None or (m.prep == "of" and m.part))]
        if action is None:
            if not self.steps or not direct:
                raise PlanError(f"no action in '{clause.text}': start with a verb such as {ACTION_WORDS}")
            action = self.steps[-1].action  # "put the tube in the rack, the vial in the box"
        counted = next((m for m in clause.mentions if m.count > 1), None)
        if counted is not None and (action not in ("pick", "place", "remove", "position") or counted.prep):
            raise PlanError(
                f"'{clause.text}': a count is read only for objects the robot moves, one after another ('put two "
                f"microtubes in the rack'); name each {counted.phrase} this step acts on"
            )

        if action in ("run", "tare"):
            self._run(clause, direct, action)
            return
        before = self.steps[-1] if self.steps else None
        if (
            action == "place"
            and len(direct) == 1
            and direct[0].is_pronoun
            and before is not None
            and before.action == "open"
            and before.object is not None
            and before.part in HATCH_PARTS
        ):  # "lift the lid off the water bath, then put it back": "it" is the part the step before opened
            self._hatch("close", clause, [before.object.mention], None, part_name=before.part)
            return
        lid = self._loose_lid(action, clause, direct)
        if lid is not None:  # "open the water bath lid", "take the bath lid off": its instrument's lid
            self._hatch(lid[0], clause, [lid[1]], None, part_name="lid")
            return
        hatch = next((p for p in clause.parts if p.name in HATCH_PARTS), None)
        words = {t.text for t in clause.tokens}
        if hatch is not None and (not direct or all(m is hatch.owner for m in direct)):
            if action in ("pick", "remove") or (
                action == "place" and not clause.with_prep("dest", "over") and ({"up", "open", "opened"} & words)
            ):
                action = "open"  # "lift the lid", "take the lid off the water bath", "pull the drawer out"
            elif action in ("place", "press"):
                action = "close"  # "put the lid back on the bath", "push the drawer in", "lower the lid"
            if action in ("open", "close", "place", "press"):
                if {"open", "opened", "out"} & words and action != "open":
                    action = "open" if "out" not in words or hatch.name in ("drawer", "sash") else action
                if {"closed", "shut"} & words:
                    action = "close"
        if action in ("open", "close", "press"):
            self._hatch(action, clause, direct, hatch)
        else:
            self._movement(action, clause, direct)

    def _loose_lid(self, action: str, clause: Clause, direct: list[Mention]) -> tuple[str, Mention] | None:
        """``(open or close, the instrument)`` when the step moves a lift-off lid: lifting or taking it
        off opens its instrument, putting it on (back) closes it."""
        if len(direct) != 1 or direct[0].is_pronoun or action not in ("open", "close", "pick", "remove", "place"):
            return None
        owners = {self.vocab.lid_owner(a) for a in self.vocab.members(direct[0].kind)}
        if len(owners) != 1 or None in owners:
            return None
        owner = str(owners.pop())
        kind = self.vocab.assets[owner].kinds[0]
        dests = [m for m in clause.with_prep("dest") if not m.is_bench]
        if action == "place" and any(owner not in self.vocab.members(m.kind) for m in dests):
            return None  # the lid goes somewhere else: a movement
        m = direct[0]
        mention = Mention(m.start, m.end, kind, m.phrase, window_start=m.window_start, part="lid")
        return ("close" if action in ("place", "close") else "open"), mention

    def _run(self, clause: Clause, direct: list[Mention], action: str = "run") -> None:
        """An instrument's run ("start the spin", "run the centrifuge", "spin the tube in it"), or a
        tare ("tare the balance", "hit the tare button"): the instrument named, or whose run is
        named, or the one the item went into."""
        places = [m for m in clause.mentions if not m.is_bench and m.prep in ("dest", "of")]
        named = [self.obj(m, clause, "instrument", []) for m in [*direct, *places]]
        instruments = [o for o in named if self._static(o)]
        items = [o for o in named if not self._static(o)]
        instrument = instruments[0] if instruments else None
        if instrument is None and items:
            instrument = self._last_place_of(items[0])
        if instrument is None:
            instrument = self.pronoun("instrument", clause)
        for item in items:  # "spin the tube in the centrifuge", "tare the beaker on the balance"
            if self._last_place_of(item) is not instrument:
                self.steps.append(RawStep("place", item, instrument))
        self.steps.append(RawStep(action, instrument))

    def _hatch(
        self, action: str, clause: Clause, direct: list[Mention], hatch: Part | None, part_name: str | None = None
    ) -> None:
        button = next((p for p in clause.parts if p.name == "button"), None)
        part = button if action == "press" else hatch
        owner = part.owner if part is not None and part.owner is not None else None
        if owner is None:
            owner = next(iter(direct), None) or next(
                (m for m in clause.mentions if not m.is_bench and m.prep in ("dest", "source", "of")), None
            )
        obj = self.obj(owner, clause, "instrument", []) if owner is not None else None
        if action == "press" and part is None and obj is not None and hatch is None:
            part = None
        name = part.name if part is not None else ("button" if action == "press" else part_name)
        self.steps.append(RawStep(action, obj, part=name))

    def _movement(self, action: str, clause: Clause, direct: list[Mention]) -> None:
        taken: list[Obj] = []
        items = []
        for m in direct:
            o = self.obj(m, clause, "item", taken)
            taken.append(o)
            items.append(o)
            for _ in range(m.count - 1):  # "two microtubes": the one named, then new ones of its kind, in turn
                self.objects.append(Obj(m, o.wanted))
                taken.append(self.objects[-1])
                items.append(self.objects[-1])
        if not items:
            raise PlanError(
                f"found no object to {clause.verb or action} in '{clause.text}'; name one from the asset library"
            )
        dests = [m for m in clause.with_prep("dest") if not m.is_bench]
        overs = clause.with_prep("over")
        sources = [m for m in clause.with_prep("source") if not m.is_bench]
        on_bench = any(m.is_bench and m.prep == "dest" for m in clause.mentions)
        source = self.obj(sources[0], clause, "holder", taken) if sources else None
        nears = [m for m in clause.with_prep("near") if not m.is_bench and not m.is_pronoun]
        relation = None
        if nears and action == "place" and not dests and not overs and not clause.implied_target:
            relation = self.vocab.words.relation_of(nears[0].prep_phrase)  # "put the tube next to the beaker"
        for m in nears[1:] if relation else nears:
            taken.append(self.obj(m, clause, "distractor", taken))  # "the rack next to the beaker": unused
        targets: list[tuple[Obj, str | None]] = []
        if relation is not None:
            targets.append((self.obj(nears[0], clause, "holder", taken), None))
        for m in dests or overs:
            o = self.obj(m, clause, "holder", taken)
            taken.append(o)
            targets.append((o, m.part))
        loose = next((p for p in clause.parts if p.owner is None and p.name not in (*HATCH_PARTS, "button")), None)
        if (
            loose is not None and not targets and not on_bench
        ):  # "open the incubator, then put the dish on the top shelf"
            owner = self._with_part(loose.name)
            if owner is not None:  # its top shelf
                targets.append((owner, loose.name))
        if clause.implied_target and not targets:
            implied = Mention(0, 0, clause.implied_target, clause.implied_target)
            targets.append((self.obj(implied, clause, "holder", taken), None))
        if (overs and not dests) or (action == "position"):
            action = "position"
        elif targets:
            action = "place"
        elif action == "place" and self._dangling_dest(clause) and not on_bench:
            targets.append((self.pronoun("holder", clause), None))
        elif (action == "pick" and source is not None and sources[0].prep_phrase in REMOVING) or (
            action == "place" and (on_bench or source is not None)
        ):
            action = "remove"
        elif action == "place" and not on_bench and self._opened():
            targets.append((self._opened()[-1], None))  # "open the cycler, load the plate, close it"
        elif action == "place" and not on_bench:
            what = " and ".join(o.wanted.words() if not o.mention.is_pronoun else "it" for o in items)
            raise PlanError(f"say where to put the {what} (e.g. 'on the balance', 'into the tube rack')")
        if action == "remove" and source is None:
            source = self._last_place_of(items[0]) or self._taken_from(items[0])
            if source is None and not on_bench and self._opened():  # "open the incubator, take out the dish"
                source = self._opened()[-1]
            if source is None:
                if on_bench:
                    raise PlanError(
                        "the object already stands on the bench; name where it should go, or where it "
                        "comes from ('from the balance')"
                    )
                raise PlanError(
                    f"say where the {items[0].wanted.words()} is taken from ('out of the rack', 'off the balance')"
                )
        counted = next((m for m in direct if m.count > 1), None)
        if counted is not None and action == "pick":  # "pick up both microtubes": held at once
            raise PlanError(
                f"'{clause.text}': the gripper holds one object at a time, so it cannot pick up {counted.count} "
                f"and hold them; say where each goes ('put both microtubes in the rack')"
            )
        for k, item in enumerate(items):
            target, part = targets[min(k, len(targets) - 1)] if targets else (None, None)
            self.steps.append(RawStep(action, item, target, source, part, relation))

    def _with_part(self, part: str) -> Obj | None:
        """The object named last whose kind has the part ``part`` (a shelf, a pan)."""
        return next((o for o in reversed(self.objects) if self.vocab.has_part(o.wanted.kind, part)), None)

    def _opened(self) -> list[Obj]:
        """Instruments an earlier step opened (or pressed open): where a bare "insert X" goes."""
        return [s.object for s in self.steps if s.action in ("open", "press") and s.object is not None]

    def _dangling_dest(self, clause: Clause) -> bool:
        """A destination word with no object after it: "put the tube in"."""
        preps = {"in", "inside", "into", "on", "onto", "back", "there"}
        return any(t.kind == "word" and not t.used and t.text in preps for t in clause.tokens[1:])

    def _taken_from(self, item: Obj) -> Obj | None:
        """Where an earlier step took ``item`` from ("take the flask off the shaker and put it down")."""
        return next((s.source for s in reversed(self.steps) if s.object is item and s.source is not None), None)

    def _last_place_of(self, item: Obj) -> Obj | None:
        for step in reversed(self.steps):
            if step.object is item and step.action == "place":
                return step.target
        return None

    # ------------------------------------------------------------------ finishing
    def finish(self, robot: str | None, thresholds: dict[str, float], instruction: str) -> TaskPlanSpec:
        self._fill_elided()
        used = [o for s in self.steps for o in (s.object, s.target, s.source) if o is not None]
        self.objects = [
            o for o in self.objects if all(o is not i for i in self.introduced) or any(o is u for u in used)
        ]
        plan, remarks = assemble(self.vocab, self.objects, self.steps, robot, thresholds, instruction)
        self.remarks += remarks
        return plan

    def _fill_elided(self) -> None:
        """A hatch step without its instrument ("open and close the lid", "open the lid, then ...")
        takes the instrument with that part named in a neighbouring step, or the plan's only one."""
        for i, step in enumerate(self.steps):
            if step.object is not None:
                continue
            near = [
                s.object
                for s in self.steps[i + 1 :] + self.steps[:i][::-1]
                if s.action in INSTRUMENT_ACTIONS and s.object
            ]
            near += [o for o in self.objects if self._static(o)]
            if not near:
                raise PlanError(f"say which instrument to {step.action} (e.g. '{step.action} the centrifuge lid')")
            step.object = near[0]


def instruction_from(description: str) -> str:
    """The description as one clean imperative sentence."""
    text = re.sub(r"\s+", " ", description).strip()
    text = re.sub(r"^(please|robot,?|hey robot,?|could you|can you|would you|kindly)\s+", "", text, flags=re.I)
    text = re.sub(r"^(please)\s+", "", text, flags=re.I)
    text = re.sub(r"\s*,?\s*(please|thanks|thank you)\s*[.!?]*$", "", text, flags=re.I)
    text = text.rstrip(" .!?")
    return (text[:1].upper() + text[1:] + ".") if text else text


def _is_goal(steps: list[list[Token]], text: str, reader: ClauseReader) -> bool:
    """Whether the first of ``steps`` only says what the task is for, before a colon and the steps
    that do it ("I need a 50 mL falcon tube spun down: open the centrifuge, ..."): no verb of its own."""
    first = steps[0] if len(steps) > 1 else []
    before, colon, _ = text.partition(":")
    words = [t.text for t in first if t.kind == "word"]
    return (
        bool(colon and words)
        and not any(reader.is_verb(first, k) for k in range(len(first)))
        and re.search(rf"\b{re.escape(words[-1])}\s*$", before.lower()) is not None
    )


def _goal_words(goal: Clause, builder: Builder, vocab: Vocabulary) -> list[str]:
    """The words of a goal clause (:func:`_is_goal`) the plan does not explain: not a function word,
    and not naming an object the plan uses."""
    planned = {o.wanted.kind for o in builder.objects}
    named = [m for m in goal.objects() if m.kind in planned]
    spans = {k for m in named for k in range(m.start, m.end)}
    skip = {*vocab.words.fillers, *vocab.words.articles, *vocab.words.pronouns}
    return [t.text for k, t in enumerate(goal.tokens) if t.kind == "word" and k not in spans and t.text not in skip]


def _without_purposes(unknown: list[str], builder: Builder, vocab: Vocabulary) -> list[str]:
    """``unknown`` without the words that say what an object of the plan is for ("... in the ice
    bucket to keep it cold": vocabulary ``purposes``)."""
    said = {w for o in builder.objects for w in vocab.words.purposes.get(o.wanted.kind, [])}
    return [p for p in unknown if not set(p.split()) <= said]


def parse_description(description: str, vocab: Vocabulary) -> ParseResult:
    """Parse ``description`` into a plan (see the module docstring).

    Raises:
        PlanError: the description is empty, negated, asks for what cannot be simulated, names
            unknown objects, or leaves out what a step needs (each with what to change).
    """
    words = vocab.words
    text = inverted_of(normalise(description, words), vocab.alias_to_kind)
    if not re.search(r"[a-z]", text):
        raise PlanError("the description is empty; say what the robot should do, e.g. 'Pick up the test tube'")
    if has_negation(text):
        raise PlanError(
            "negations are not supported: describe what the robot should do, e.g. 'Close the centrifuge lid'"
        )
    text, thresholds = extract_thresholds(text)
    text, robots = robot_mentions(text)
    if len(robots) > 1:
        raise PlanError(f"contradictory request: it names {len(robots)} robots ({', '.join(robots)}); a task has one")
    reader = ClauseReader(vocab)
    steps = split_steps(text, reader.is_verb, vocab)
    goal = reader.read(steps.pop(0)) if _is_goal(steps, text, reader) else None
    parts, earlier, conditions = subordinates(steps, reader.is_verb)
    clauses = [reader.read(part) for part in parts]
    if not clauses:
        raise PlanError("the description is empty; say what the robot should do, e.g. 'Pick up the test tube'")
    refuse_unsupported(clauses, vocab)
    builder = Builder(vocab)
    if goal is not None:
        builder.introduce(goal)
    said = [w for w in conditions if w in CONDITIONS or w not in {*words.articles, *words.fillers}]
    unknown = refuse_unknown(clauses, vocab) + said  # a condition's opening word and what it says
    try:
        starts: list[int] = []
        for i, clause in enumerate(clauses):
            starts.append(len(builder.steps))
            builder.add(clause)
            if i in earlier:  # "start the cycler after closing its lid": read after the main clause, done before it
                main, sub = starts[earlier[i]], starts[i]
                builder.steps[main:] = builder.steps[sub:] + builder.steps[main:sub]
        plan = builder.finish(robots[0] if robots else None, thresholds, instruction_from(description))
        unknown += _goal_words(goal, builder, vocab) if goal is not None else []
        unknown = _without_purposes(unknown, builder, vocab)
    except PlanError as exc:
        if not unknown:
            raise
        raise PlanError(f"{exc} ({not_understood_line(unknown, None)})", final=exc.final) from None
    return ParseResult(plan, builder.remarks, unknown)
