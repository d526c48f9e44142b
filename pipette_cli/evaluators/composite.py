"""``all``, ``any`` and ``sequence``: criteria built from other criteria.

Children are built with :func:`~pipette_cli.evaluators.base.make_evaluator`, so any
registered family (third-party ones included) may be a child, and composites nest.

* ``all`` resets every child at its own reset and updates every child on every step. It
  succeeds on the first step where every child is satisfied *at the same time*: each
  child's own hold is complete and its condition still holds (a child that was satisfied
  earlier and broke must hold again). It fails as soon as any child fails, with that
  child's reason (the first in spec order when several fail on one step).
* ``any`` resets and updates every child; it succeeds on the first step where some child
  is satisfied and fails when every child has failed, with the first child's reason.
* ``sequence`` resets and updates only the current stage. On the step a stage is satisfied
  the next stage is reset, so its references (initial pose, tilt axis) and its own
  ``timeout_s`` clock start then, and it is first updated on the following step. The
  sequence succeeds when its last stage is satisfied and fails when the current stage
  fails, with that stage's reason.

A composite's own ``timeout_s`` (measured from its reset) applies on top of its children's;
when it expires, the reason is the unmet reason of the first child not satisfied (e.g.
``"out_of_region"``), or ``"timeout"``.

Children that derive from :class:`~pipette_cli.evaluators.condition.ConditionEvaluator`
(every built-in) are asked "satisfied now?" through their ``advance`` method; a child that
only implements the :class:`~pipette_cli.evaluators.base.Evaluator` protocol is asked
through ``update``, so its success is latched and counts as satisfied from then on.

Metrics: every child's metrics prefixed with its index (``"0.height_gain"``), plus
``satisfied`` (children satisfied on this step) for ``all``/``any``, and for ``sequence`` ``stage``
(index of the stage being checked; the number of stages once done) and ``stages`` (how many
there are): ``stage / stages`` is the episode's progress through a staged task.

A ``sequence`` also says which stage it is on (:attr:`Sequence.stage`) and that stage's
``instruction`` (:meth:`Sequence.stage_instruction`, nested sequences included), which the world
hands out as the instruction of the moment.
"""

from __future__ import annotations

from pipette_cli.evaluators.base import Evaluator, Verdict, WorldState, make_evaluator, register
from pipette_cli.evaluators.condition import TIMEOUT, Check, ConditionEvaluator
from pipette_cli.specs.evaluators import AllOfSpec, AnyOfSpec, CompositeSpec, SequenceSpec


def advance_child(child: Evaluator, state: WorldState) -> Verdict:
    """Update ``child`` without latching its success when it supports that (see module doc)."""
    advance = getattr(child, "advance", None)
    return advance(state) if callable(advance) else child.update(state)


def child_unmet(child: Evaluator) -> str:
    """Why ``child`` is not satisfied, as far as it says; ``"timeout"`` otherwise."""
    reason = getattr(child, "unmet", None)
    return reason if isinstance(reason, str) else TIMEOUT


class Composite(ConditionEvaluator[CompositeSpec]):
    """Base of the composites: builds the children and merges their metrics."""

    spec_type = CompositeSpec

    def __init__(self, spec: CompositeSpec) -> None:
        super().__init__(spec)
        self.children: list[Evaluator] = [make_evaluator(child) for child in spec.of]
        self._last: list[Verdict | None] = [None] * len(self.children)

    def start(self, state: WorldState) -> None:
        self._last = [None] * len(self.children)
        for child in self.children:
            child.reset(state)

    def prime(self, state: WorldState) -> None:
        for child in self.children:
            prime = getattr(child, "prime", None)
            if prime is not None:
                prime(state)

    def _metrics(self) -> dict[str, float]:
        metrics: dict[str, float] = {}
        for i, verdict in enumerate(self._last):
            if verdict is not None:
                metrics.update({f"{i}.{key}": value for key, value in verdict.metrics.items()})
        return metrics

    def _advance_all(self, state: WorldState) -> list[Verdict]:
        self._last = [advance_child(child, state) for child in self.children]
        return [v for v in self._last if v is not None]


@register("all")
class AllOf(Composite):
    """Runtime of :class:`~pipette_cli.specs.evaluators.AllOfSpec`: every child at once."""

    spec_type = AllOfSpec

    def check(self, state: WorldState) -> Check:
        verdicts = self._advance_all(state)
        metrics = {**self._metrics(), "satisfied": float(sum(v.success for v in verdicts))}
        failed = next((v for v in verdicts if v.failed), None)
        if failed is not None:
            return Check(False, metrics, fail=failed.reason or TIMEOUT)
        pending = next((c for c, v in zip(self.children, verdicts, strict=True) if not v.success), None)
        return Check(pending is None, metrics, unmet=None if pending is None else child_unmet(pending))


@register("any")
class AnyOf(Composite):
    """Runtime of :class:`~pipette_cli.specs.evaluators.AnyOfSpec`: the first child to succeed."""

    spec_type = AnyOfSpec

    def check(self, state: WorldState) -> Check:
        verdicts = self._advance_all(state)
        metrics = {**self._metrics(), "satisfied": float(sum(v.success for v in verdicts))}
        if any(v.success for v in verdicts):
            return Check(True, metrics)
        if all(v.failed for v in verdicts):
            return Check(False, metrics, fail=verdicts[0].reason or TIMEOUT)
        alive = next(c for c, v in zip(self.children, verdicts, strict=True) if not v.failed)
        return Check(False, metrics, unmet=child_unmet(alive))


@register("sequence")
class Sequence(Composite):
    """Runtime of :class:`~pipette_cli.specs.evaluators.SequenceSpec`: children in order."""

    spec_type = SequenceSpec

    def __init__(self, spec: CompositeSpec) -> None:
        super().__init__(spec)
        self._stage = 0
        self._done = False

    def start(self, state: WorldState) -> None:
        self._last = [None] * len(self.children)
        self._stage = 0
        self._done = False
        self.prime(state)
        self.children[0].reset(state)

    def check(self, state: WorldState) -> Check:
        child = self.children[self._stage]
        verdict = advance_child(child, state)
        self._last[self._stage] = verdict
        if verdict.failed:
            return Check(False, self._staged(self._stage), fail=verdict.reason or TIMEOUT)
        if not verdict.success:
            return Check(False, self._staged(self._stage), unmet=child_unmet(child))
        if self._stage == len(self.children) - 1:
            self._done = True
            return Check(True, self._staged(len(self.children)))
        self._stage += 1
        self.children[self._stage].reset(state)
        return Check(False, self._staged(self._stage), unmet=TIMEOUT)

    def _staged(self, stage: int) -> dict[str, float]:
        return {**self._metrics(), "stage": float(stage), "stages": float(len(self.children))}

    @property
    def stage(self) -> int:
        """Index of the stage being checked; the number of stages once the sequence succeeded."""
        return len(self.children) if self._done else self._stage

    def stage_instruction(self) -> str | None:
        """The instruction of the stage being checked (the last stage's once done): the innermost
        one given, where a stage is itself a sequence."""
        child = self.children[min(self._stage, len(self.children) - 1)]
        inner = getattr(child, "stage_instruction", None)
        text = inner() if callable(inner) else None
        return text or child.spec.instruction
